"""The bad-input corpus for the readers of a user's files: sidecars and scene files declaring huge arrays, nested
thousands deep, holding strings of megabytes or larger than such a file ever is; a full disk under the cache; a
LabelMe shape outside the photo (a warning, the run goes on)."""

from __future__ import annotations

import base64
import io
import re
import shutil
import struct
import subprocess
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from bad_input import (
    LABELME,
    Case,
    edit,
    encoded,
    example,
    labelme,
    overrides,
    run_case,
    scene_folder,
    with_sidecar,
)

DEEP = "[" * 10_000 + "]" * 10_000
"""A JSON value nested 10,000 levels deep (Python's parser recurses once per level)."""


def npy_header(shape: tuple[int, ...], descr: str = "<f4", data: bytes = b"\0" * 16) -> bytes:
    """An .npy file whose header declares ``shape`` of ``descr`` values, followed by ``data`` only."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue() + data


def png_header(width: int, height: int) -> bytes:
    """A 16-bit gray PNG whose header declares ``width`` x ``height`` pixels, with a few rows of data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0)
    rows = zlib.compress(b"\0" * (1 + 2 * width) * 4)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", rows) + chunk(b"IEND", b"")


def panoptic_with_json(text: str) -> Callable[[Path], list[str]]:
    """The example photo with an RGB panoptic PNG and ``text`` as its JSON."""

    def setup(folder: Path) -> list[str]:
        ids = np.zeros((480, 640, 3), np.uint8)
        ids[:240] = (1, 0, 0)
        photo = example(folder, {".panoptic.png": encoded(ids), ".panoptic.json": text})
        return [f"image={photo}", "fov=fixed", "detector=none", "run.until=segment"]

    return setup


MASK_SHAPE = {
    "label": "rug",
    "points": [[0, 0], [4, 4]],
    "shape_type": "mask",
    "mask": base64.b64encode(encoded(np.full((4, 4), 255, np.uint8))).decode(),
}

CASES: dict[str, Case] = {
    "depth_npy_huge_shape": Case(
        with_sidecar(".depth.npy", npy_header((100_000, 100_000))),
        "photo.depth.npy: the header declares a 100000x100000 float32 array (40.0 GB)",
    ),
    "depth_npy_huge_values": Case(
        with_sidecar(".depth.npy", npy_header((480, 640), "<U100000000")),
        "photo.depth.npy: the header declares a 480x640 <U100000000 array",
    ),
    "depth_png_huge_header": Case(
        with_sidecar(".depth.png", png_header(20_000, 20_000)),
        "photo.depth.png: the header declares 20000x20000 pixels",
    ),
    "depth_json_nested_deep": Case(
        with_sidecar(".depth.json", '{"encoding": ' + DEEP + "}", beside=(".depth.png",)),
        "photo.depth.json: nested more than 32 levels deep",
    ),
    "depth_json_oversized": Case(
        with_sidecar(
            ".depth.json", '{"encoding": "png16",' + " " * 2_000_000 + '"scale": 1000}', beside=(".depth.png",)
        ),
        "photo.depth.json: 2.0 MB, larger than such a file ever is (at most 1.0 MB)",
    ),
    "labelme_nested_deep": Case(
        with_sidecar(".labelme.json", '{"shapes": ' + DEEP + "}"), "photo.labelme.json: nested more than 32 levels deep"
    ),
    "labelme_image_size_huge": Case(
        with_sidecar(".labelme.json", labelme(imageHeight=1_000_000, imageWidth=1_000_000, shapes=[MASK_SHAPE])),
        "photo.labelme.json: imageHeight/imageWidth 1000000x1000000",
    ),
    "panoptic_json_nested_deep": Case(
        panoptic_with_json('{"segments_info": ' + DEEP + "}"), "photo.panoptic.json: nested more than 32 levels deep"
    ),
    "edit_nested_deep": Case(
        edit("light.scale=2", appearance='{"camera": ' + DEEP + "}"),
        "appearance.json: nested more than 32 levels deep",
        "psdr-room-edit",
    ),
    "edit_string_50mb": Case(
        edit("light.scale=2", appearance={"texture_size": "x" * 50_000_000}),
        "appearance.json: a string of 50,000,000 characters",
        "psdr-room-edit",
    ),
    "edit_long_value_cut": Case(
        edit("light.scale=2", appearance={"texture_size": "y" * 2000}),
        'appearance.json: texture_size="' + "y" * 78 + "… is invalid",
        "psdr-room-edit",
    ),
    "edit_part_name_long": Case(
        edit("light.scale=2", appearance={"fixtures": ["../" + "z" * 3000]}),
        "fixture '../" + "z" * 75 + "… is not a plain name",
        "psdr-room-edit",
    ),
    "boxes_nested_deep": Case(
        with_sidecar(".boxes.yaml", "boxes: " + DEEP), "photo.boxes.yaml: nested too deep to read"
    ),
    "boxes_oversized": Case(
        with_sidecar(".boxes.yaml", "boxes:\n" + "  - {label: sofa, box: [1, 1, 9, 9]}\n" * 200_000),
        "photo.boxes.yaml: 7.4 MB, larger than a boxes file ever is",
    ),
    "override_value_long": Case(
        overrides("room_fit.iterations=" + "9a" * 2000),
        "room_fit.iterations=" + "9a" * 39 + "9… is invalid",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_reader_input_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)


@pytest.mark.parametrize("value", ["x" * 50_000_000, "y" * 2000])
def test_bad_value_is_echoed_short(value: str, tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A long bad value in appearance.json shows at most 80 of its characters in the error line."""
    scene = scene_folder(tmp_path, {"texture_size": value})
    program = shutil.which("psdr-room-edit") or "psdr-room-edit"
    result = subprocess.run(
        [program, str(scene), "light.scale=2", "--out", str(tmp_path / "edited")],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode != 0
    (line,) = [line for line in result.stderr.splitlines() if "error" in line]
    assert max(len(run) for run in re.findall(f"{value[0]}+", line)) <= 80, line[:300]
    assert len(line) < 300 + len(str(scene)), line[:300]


def test_labelme_shape_outside_photo_is_dropped_with_a_warning(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A LabelMe polygon lying outside the photo is left out, in one warning line naming the file and the shape; the
    run goes on."""
    outside = {"label": "chair", "points": [[700, 500], [800, 500], [800, 600]], "shape_type": "polygon"}
    photo = example(tmp_path, {".labelme.json": labelme(shapes=[*LABELME["shapes"], outside])})
    program = shutil.which("psdr-room") or "psdr-room"
    result = subprocess.run(
        [
            program,
            f"image={photo}",
            "fov=fixed",
            "detector=none",
            "run.until=segment",
            f"hydra.run.dir={tmp_path / 'run'}",
        ],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stderr.splitlines() if "dropped" in line]
    shape = len(LABELME["shapes"])
    assert len(lines) == 1, result.stderr
    assert f"photo.labelme.json: shape {shape} ('chair')" in lines[0] and "outside the 640x480 photo" in lines[0]


def test_full_disk_under_the_cache_is_named(tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    """A cache on a full disk: one line naming the cache folder and saying there is no space left (no stray libpng
    line), nothing left in the cache's temporary folder. The disk is a 64 kB tmpfs mounted over the cache folder in
    a private mount namespace (``unshare``), so the run meets a real ENOSPC and the mount ends with the process."""
    cache_dir.mkdir()
    mount = 'mount -t tmpfs -o size=64k psdr-room-test "$0"'
    unshare = shutil.which("unshare")
    if unshare is None or subprocess.run([unshare, "-Urm", "sh", "-c", mount, str(cache_dir)]).returncode != 0:
        pytest.skip("cannot mount a small tmpfs in a private mount namespace here")
    photo = example(tmp_path)
    run_dir = tmp_path / "run"
    script = f'{mount} && "$@"; code=$?; echo "left in tmp: $(ls -A "$0/tmp" | wc -l)"; exit $code'
    program = shutil.which("psdr-room") or "psdr-room"
    result = subprocess.run(
        [unshare, "-Urm", "sh", "-c", script, str(cache_dir), program, f"image={photo}", f"hydra.run.dir={run_dir}"],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode != 0, result.stderr
    lines = [line for line in result.stderr.splitlines() if any(w in line.lower() for w in ("error", "warn", "trace"))]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"psdr-room: error: {cache_dir}: no space left on device"), lines[0]
    assert "left in tmp: 0" in result.stdout, result.stdout
    assert not (run_dir / "metrics.json").exists()


def test_full_disk_under_the_run_folder_is_named(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A run folder on a full disk (a 64 kB tmpfs in a private mount namespace, as above): one line naming the
    folder and saying there is no space left, not an internal error."""
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    mount = 'mount -t tmpfs -o size=64k psdr-room-test "$0"'
    unshare = shutil.which("unshare")
    if unshare is None or subprocess.run([unshare, "-Urm", "sh", "-c", mount, str(run_dir)]).returncode != 0:
        pytest.skip("cannot mount a small tmpfs in a private mount namespace here")
    program = shutil.which("psdr-room") or "psdr-room"
    args = [f"image={example(tmp_path)}", "run.until=load_image", f"hydra.run.dir={run_dir}"]
    result = subprocess.run(
        [unshare, "-Urm", "sh", "-c", f'{mount} && exec "$@"', str(run_dir), program, *args],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if any(w in line.lower() for w in ("error", "warn", "trace"))]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"psdr-room: error: {run_dir}") and "no space left on device" in lines[0], lines[0]
