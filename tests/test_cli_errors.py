"""Bad input: one line on stderr naming the file or key and the fix, a non-zero exit, no traceback, no outputs."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest

from conftest import EXAMPLE


def run_cli(args: list[str], env: dict[str, str], run_dir: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([shutil.which("psdr-room") or "psdr-room", *args, f"hydra.run.dir={run_dir}"],
                          env=env, capture_output=True, text=True, timeout=300)


def copy_example(tmp_path: Path, photo_bytes: bytes | None = None, name: str = "photo.jpg") -> Path:
    folder = tmp_path / "photo"
    shutil.copytree(EXAMPLE.parent, folder)
    photo = folder / name
    if photo_bytes is not None:
        photo.write_bytes(photo_bytes)
    return photo


def png(tmp_path: Path, rgb: np.ndarray, name: str = "photo.png") -> Path:
    path = tmp_path / name
    cv2.imwrite(str(path), rgb[..., ::-1])
    return path


def user_files_in_run_dir(tmp_path: Path) -> list[str]:
    """The run directory already holds the user's own ``scene/`` folder (no psdr-room marker)."""
    (tmp_path / "run" / "scene").mkdir(parents=True)
    (tmp_path / "run" / "scene" / "mine.blend").write_text("the user's")
    return [f"image={EXAMPLE}"]


CASES = {
    "directory": (lambda t: [f"image={t}"], "is a directory"),
    "too_small": (lambda t: [f"image={png(t, np.random.default_rng(0).integers(0, 255, (40, 300, 3), np.uint8))}"],
                  "too small"),
    "one_colour": (lambda t: [f"image={png(t, np.full((120, 160, 3), 90, np.uint8))}"], "same colour"),
    "max_side_zero": (lambda t: [f"image={EXAMPLE}", "load_image.max_side=0"], "load_image.max_side=0"),
    "path_with_equals": (lambda t: [f"image={t / 'my,room=1.jpg'}"], "quote it: image=\"'"),
    "path_with_comma": (lambda t: [f"image={t / 'my,room.jpg'}"], "quote the path"),
    "run_dir_not_ours": (user_files_in_run_dir, "psdr-room did not write"),
    "missing_file": (lambda t: [f"image={t / 'nope.jpg'}"], "nope.jpg: no such file"),
    "not_an_image": (lambda t: [f"image={copy_example(t, b'hello, not a JPEG')}"], "not an image"),
    "truncated_jpeg": (lambda t: [f"image={copy_example(t, EXAMPLE.read_bytes()[:20000])}"], "damaged or truncated"),
    "too_many_pixels": (lambda t: [f"image={EXAMPLE}", "load_image.max_pixels=1000"], "over load_image.max_pixels=1000"),
    "unknown_implementation": (lambda t: [f"image={EXAMPLE}", "fov=nope"],
                               "unknown fov implementation 'nope'; valid names: fixed, vanishing_points"),
    "bad_override_syntax": (lambda t: [f"image={EXAMPLE}", "room_init.ransac_threshold=[0.1"], "invalid override"),
    "unknown_key": (lambda t: [f"image={EXAMPLE}", "room_init.ransac_treshold=0.1"], "ransac_treshold"),
    "no_image": (lambda t: [], "image is required; add image=PATH/TO/photo.jpg"),
    "bad_cache_mode": (lambda t: [f"image={EXAMPLE}", "cache=sometimes"], "cache=sometimes is not a cache mode"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_gets_one_line(case: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    make_args, expected = CASES[case]
    result = run_cli(make_args(tmp_path), cli_env, tmp_path / "run")
    assert result.returncode != 0
    lines = [line for line in result.stderr.splitlines() if line.strip() and not line.startswith(("▶", "✗"))]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("psdr-room: error: ") and expected in lines[0], lines[0]
    assert "Traceback" not in result.stderr + result.stdout
    assert not (tmp_path / "run" / "metrics.json").exists()
    if case == "run_dir_not_ours":
        assert [p.name for p in (tmp_path / "run" / "scene").iterdir()] == ["mine.blend"]
    if (cache_dir / "tmp").exists():
        assert not list((cache_dir / "tmp").iterdir())  # no half-written cache entry
