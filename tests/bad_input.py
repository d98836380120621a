"""Shared by the bad-input corpus (``test_bad_input*.py``): the :class:`Case` record, builders of broken photos,
sidecars and scene folders, and :func:`run_case`, which runs one case and checks the corpus's promise: a
non-zero exit and exactly one error line on stderr that names the file or key, no traceback, no published
output, no damaged or half-written cache entry, and every file outside the run directory and the cache exactly
as it was (the case's own files and a sentinel folder are hashed before and after)."""

from __future__ import annotations

import hashlib
import io
import json
import shutil
import subprocess
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from conftest import EXAMPLE
from psdr_room_core.engine.cache import Store, damage
from psdr_room_core.engine.ownership import claim

RNG_PHOTO = np.random.default_rng(0).integers(0, 255, (120, 160, 3), np.uint8)


@dataclass(frozen=True)
class Case:
    setup: Callable[[Path], list[str]]
    """Writes the case's files under the given folder; returns the command line after the program."""
    expected: str
    """Part of the one error line: the file or key it names and what is wrong."""
    program: str = "psdr-room"


# ------------------------------------------------------------------------------------------ helpers
def png(folder: Path, rgb: np.ndarray, name: str = "photo.png") -> Path:
    path = folder / name
    cv2.imwrite(str(path), rgb[..., ::-1])
    return path


def example(folder: Path, sidecars: dict[str, bytes | str] | None = None, photo: bytes | None = None) -> Path:
    """The bundled example photo, alone in ``folder/photo`` (with ``sidecars``: suffix → content)."""
    (folder / "photo").mkdir()
    target = folder / "photo" / EXAMPLE.name
    target.write_bytes(EXAMPLE.read_bytes() if photo is None else photo)
    for suffix, content in (sidecars or {}).items():
        path = target.with_name(target.stem + suffix)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return target


def with_sidecar(
    suffix: str, content: bytes | str | Callable[[], bytes], beside: tuple[str, ...] = ()
) -> Callable[[Path], list[str]]:
    """The example with one broken sidecar (and the example's own sidecars with the suffixes ``beside``);
    its LabelMe file (unless that is the broken one) and no detector unless boxes are tested keep the
    stages before the failing one quick; ``run.until`` stops a run that missed the fault."""

    def setup(folder: Path) -> list[str]:
        data = content() if callable(content) else content
        sidecars = {s: EXAMPLE.with_name(EXAMPLE.stem + s).read_bytes() for s in beside}
        if suffix.startswith(".depth"):
            sidecars[".labelme.json"] = LABELME_TEXT
        photo = example(folder, {**sidecars, suffix: data})
        return [
            f"image={photo}",
            "fov=fixed",
            "run.until=estimate_depth",
            *([] if suffix == ".boxes.yaml" else ["detector=none"]),
        ]

    return setup


def overrides(*args: str) -> Callable[[Path], list[str]]:
    return lambda folder: [f"image={example(folder)}", *args]


def encoded(array: np.ndarray, ext: str = ".png") -> bytes:
    return cv2.imencode(ext, array)[1].tobytes()


def npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


LABELME_TEXT = EXAMPLE.with_name(EXAMPLE.stem + ".labelme.json").read_text()
LABELME = json.loads(LABELME_TEXT)


def labelme(**changes: object) -> str:
    return json.dumps({**LABELME, **changes})


def scene_folder(folder: Path, appearance: dict | str | None = None) -> Path:
    """A scene folder as psdr-room-edit reads it: ``appearance.json`` (edits are refused before meshes are read)."""
    scene = folder / "scene"
    scene.mkdir()
    state = {
        "camera": {"width": 160, "height": 120, "fx": 150.0, "fy": 150.0, "cx": 79.5, "cy": 59.5},
        "camera_to_world": np.eye(4).tolist(),
        "parts": [
            {
                "part": "floor",
                "kind": "homogeneous",
                "base_color": [0.5, 0.4, 0.3],
                "roughness": 0.5,
                "specular": 0.5,
                "material": None,
                "scale": 1.0,
                "rotation": 0.0,
                "params": {},
            }
        ],
        "lights": [{"name": "light_ceiling_1", "kind": "ceiling", "part": None, "radiance": [5.0, 5.0, 5.0]}],
        "fixtures": [],
        "texture_size": 64,
    }
    if isinstance(appearance, dict):
        state.update(appearance)
    text = appearance if isinstance(appearance, str) else json.dumps(state)
    (scene / "appearance.json").write_text(text)
    claim(scene)
    return scene


def edit(*args: str, appearance: dict | str | None = None) -> Callable[[Path], list[str]]:
    return lambda folder: [str(scene_folder(folder, appearance)), *args, "--out", str(folder / "edited")]


def edit_into_users_folder(folder: Path) -> list[str]:
    (folder / "mine").mkdir()
    (folder / "mine" / "notes.txt").write_text("the user's")
    return [str(scene_folder(folder)), "light.scale=2", "--out", str(folder / "mine")]


def users_files_in_run_dir(folder: Path) -> list[str]:
    (folder / "run" / "scene").mkdir(parents=True)
    (folder / "run" / "scene" / "mine.blend").write_text("the user's")
    return [f"image={example(folder)}"]


def run_dir_of_another_app(folder: Path) -> list[str]:
    (folder / "run" / ".hydra").mkdir(parents=True)
    (folder / "run" / ".hydra" / "config.yaml").write_text("their_app: 1\n")
    (folder / "run" / "their_results.csv").write_text("a,b\n")
    return [f"image={example(folder)}"]


def run_dir_with_notes(folder: Path) -> list[str]:
    (folder / "run").mkdir()
    (folder / "run" / "notes.txt").write_text("the user's")
    return [f"image={example(folder)}"]


def run_dir_is_a_file(folder: Path) -> list[str]:
    (folder / "run").write_text("the user's")
    return [f"image={example(folder)}"]


def part(**changes: object) -> dict:
    """The floor part of :func:`scene_folder`'s scene with ``changes``."""
    return {
        "part": "floor",
        "kind": "homogeneous",
        "base_color": [0.5, 0.4, 0.3],
        "roughness": 0.5,
        "specular": 0.5,
        "material": None,
        "scale": 1.0,
        "rotation": 0.0,
        "params": {},
        **changes,
    }


def cache_dir_is_a_file(folder: Path) -> list[str]:
    (folder / "not_a_dir").write_text("the user's")
    return [f"image={example(folder)}", f"cache_dir={folder / 'not_a_dir'}"]


def gif(folder: Path) -> Path:
    import PIL.Image

    path = folder / "photo.gif"
    PIL.Image.fromarray(RNG_PHOTO).save(path)
    return path


def snapshot(folder: Path, skip: tuple[Path, ...]) -> dict[str, str]:
    """Content digest of every file under ``folder`` outside ``skip``."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not any(p.is_relative_to(s) for s in skip)
    }


def run_case(case: Case, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    """Run ``case`` in ``tmp_path`` and check the corpus's promise (the module docstring)."""
    files = tmp_path / "user"
    files.mkdir()
    (files / "sentinel").mkdir()
    (files / "sentinel" / "keep.txt").write_text("must not change")
    run_dir = files / "run"
    args = case.setup(files)
    if case.program == "psdr-room":
        args.append(f"hydra.run.dir={run_dir}")
    # Hydra's files in a run folder it made (a case that fails once stages run); a folder that was there stays as it was
    hydra_own = () if run_dir.exists() else (run_dir / ".hydra", run_dir / "psdr-room.log", run_dir / ".psdr-room")
    before = snapshot(files, hydra_own)
    result = subprocess.run(
        [shutil.which(case.program) or case.program, *args], env=cli_env, capture_output=True, text=True, timeout=300
    )
    assert result.returncode != 0, result.stdout + result.stderr
    lines = [
        line for line in result.stderr.splitlines() if any(w in line.lower() for w in ("error", "warn", "traceback"))
    ]
    assert len(lines) == 1, result.stderr  # besides the progress lines (▶ ✓ ✗) and the log's choices
    assert lines[0].startswith(f"{case.program}: error: ") and case.expected in lines[0], lines[0]
    assert "Traceback" not in result.stderr + result.stdout and "To append to your config" not in result.stderr
    assert snapshot(files, hydra_own) == before  # nothing of the user's changed (run_dir_not_ours: run/scene/)
    assert not (run_dir / "metrics.json").exists() and not (files / "edited").exists()
    if run_dir.is_dir() and not hydra_own:
        assert not [p for p in run_dir.iterdir() if p.name.startswith(".publishing-")]
    if cache_dir.is_dir():
        assert not [e for e in Store(cache_dir).entries() if damage(e)]
        assert not list((cache_dir / "tmp").glob("*"))
