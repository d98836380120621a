"""``psdr-room-blender``: an exported scene folder as a Blender scene ready to render (``scene.blend``).

    psdr-room-blender outputs/.../scene                       # writes outputs/.../scene/scene.blend
    psdr-room-blender outputs/.../scene --render cycles.png --engine cycles --width 320

Blender (3.4 or newer, e.g. Debian's ``blender`` with ``python3-numpy``, which its glTF importer needs) builds
the scene with :mod:`.blender_scene`: the photo's camera active at the photo's resolution, area lights of the
fitted radiance, Principled BSDFs with the fitted colour, roughness, specular and maps, ``Standard`` colour
management; Cycles and EEVEE both render it lit. ``--render`` also renders the camera's view to a PNG; a
Cycles render is cleaned by psdr-room's ``--denoiser`` (default ``oidn``, as psdr-room's own renders are:
Debian's Blender is built without a denoiser of its own). The .blend and the render are written in a scratch
folder of kind ``blender`` beside each and renamed into place when complete; what a killed run left there is
removed first.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.debris import scratch_dir, sweep
from psdr_room_core.engine.errors import PsdrRoomError, exit_status
from psdr_room_core.engine.files import check_creatable, move_into_place
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.method.artifacts import write_png
from psdr_room_core.method.capabilities import Denoiser
from psdr_room_core.method.rgb_scene import to_srgb8
from psdr_room_core.method.shading import srgb_to_linear

SCRIPT = Path(__file__).with_name("blender_scene.py")
"""The script Blender runs (its own Python: nothing of psdr-room is imported there)."""
BLENDER = "blender"
"""The scratch kind of the files psdr-room-blender writes."""
INSTALL = "install Blender 3.4 or newer (Debian: sudo apt-get install blender python3-numpy) or pass --blender PATH"


def find_blender(given: str | None) -> str:
    """The Blender executable: ``given``, else ``$PSDR_ROOM_BLENDER``, else ``blender`` on the PATH."""
    name = given or os.environ.get("PSDR_ROOM_BLENDER") or "blender"
    found = shutil.which(name)
    if found is None:
        raise PsdrRoomError(f"{name}: Blender not found; {INSTALL}")
    return found


def check_scene(scene: Path) -> None:
    """Refuse a folder that is not an exported scene with glb (before Blender starts)."""
    for name in ("scene.glb", "appearance.json", "scene.xml"):
        if not (scene / name).is_file():
            raise PsdrRoomError(
                f"{scene}: no {name}; pass the scene/ folder of a psdr-room run (export_scene.glb=true)"
            )


def check_output(path: Path, flag: str) -> None:
    """Refuse, before Blender starts, an output ``path`` (given by ``flag``) that is a folder or lies under a file."""
    if path.is_dir():
        raise PsdrRoomError(f"{flag} {path}: is a folder; give the path of the file to write")
    check_creatable(path, flag)


def build_blend(
    scene: Path,
    blend: Path,
    blender: str,
    render: Path | None = None,
    engine: str = "cycles",
    spp: int = 64,
    width: int | None = None,
    timeout: float = 1800.0,
) -> None:
    """Run Blender on the scene folder ``scene``: save ``blend`` and, with ``render``, a PNG of the camera's view."""
    check_scene(scene)
    command = [
        blender,
        "-b",
        "--factory-startup",
        "--python-exit-code",
        "1",
        "--python",
        str(SCRIPT),
        "--",
        str(scene),
        "--blend",
        str(blend),
        "--engine",
        engine,
        "--spp",
        str(spp),
        *(["--render", str(render)] if render else []),
        *(["--width", str(width)] if width else []),
    ]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise PsdrRoomError(f"{scene}: Blender did not finish in {timeout:.0f} s") from None
    if result.returncode != 0:
        output = result.stdout + result.stderr
        if "No module named 'numpy'" in output:
            raise PsdrRoomError(f"{blender}: Blender's glTF importer needs numpy; {INSTALL}")
        lines = [line for line in output.splitlines() if line.strip() and not line.startswith("Fra:")]
        error = next((line for line in reversed(lines) if "Error" in line), lines[-1] if lines else "no output")
        raise PsdrRoomError(f"{scene}: Blender failed (exit {result.returncode}): {error.strip()}")


def denoise_png(png: Path, denoiser: Denoiser) -> None:
    """Replace the sRGB render ``png`` by its version cleaned by ``denoiser``."""
    bgr = cv2.imread(str(png))
    if bgr is None:
        raise PsdrRoomError(f"{png}: Blender wrote no readable render; rerun, or render without a denoiser")
    noisy = srgb_to_linear(bgr[..., ::-1].astype(np.float32) / 255.0)
    with tempfile.NamedTemporaryFile(suffix=".png", dir=png.parent, delete=False) as staging:
        write_png(Path(staging.name), to_srgb8(denoiser.denoise(noisy)))
    os.replace(staging.name, png)


def write_outputs(
    scene: Path,
    blend: Path,
    blender: str,
    render: Path | None,
    engine: str,
    spp: int,
    width: int | None,
    denoiser: Denoiser,
) -> None:
    """:func:`build_blend` into scratch folders of kind :data:`BLENDER` beside ``blend`` and ``render`` (after
    removing what a killed run left there), a Cycles render cleaned by ``denoiser``, then both renamed into place."""
    targets = [path.absolute() for path in (blend, *([render] if render else []))]
    folders = list(dict.fromkeys(target.parent for target in targets))
    for folder in folders:
        sweep(folder, BLENDER)
    scratch = {folder: scratch_dir(folder, BLENDER) for folder in folders}
    try:
        staged = [scratch[target.parent] / name for name, target in zip(("scene.blend", "render.png"), targets)]
        build_blend(scene, staged[0], blender, staged[1] if render else None, engine, spp, width)
        if render and engine == "cycles":
            denoise_png(staged[1], denoiser)
        for new, target in zip(staged, targets):
            move_into_place(new, target, BLENDER)
    finally:
        for folder in scratch.values():
            shutil.rmtree(folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``psdr-room-blender``."""
    parser = argparse.ArgumentParser(
        prog="psdr-room-blender",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("scene", type=Path, help="a run's scene/ folder (or an edited one)")
    parser.add_argument("--out", type=Path, help="the .blend to write (default: <scene>/scene.blend)")
    parser.add_argument("--render", type=Path, help="also render the photo's camera to this PNG")
    parser.add_argument(
        "--engine", choices=("cycles", "eevee"), default="cycles", help="the scene's render engine (default cycles)"
    )
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (Cycles) or TAA samples (EEVEE)")
    parser.add_argument("--width", type=int, help="render width in pixels (default: the photo's; aspect kept)")
    parser.add_argument(
        "--denoiser",
        default="oidn",
        help="a denoiser implementation for a Cycles render (default oidn; none: Cycles' noisy image)",
    )
    parser.add_argument("--blender", help="the Blender executable (default: $PSDR_ROOM_BLENDER or blender)")
    args = parser.parse_args(argv)
    blend = args.out or args.scene / "scene.blend"
    logging.basicConfig(level=logging.WARNING, format="%(message)s")  # warnings (a swept scratch folder) on stderr

    def write() -> None:
        if args.spp < 1 or (args.width is not None and args.width < 8):
            raise PsdrRoomError("--spp must be at least 1 and --width at least 8")
        check_scene(args.scene)
        check_output(blend, "--out")
        if args.render:
            check_output(args.render, "--render")
        denoiser = plugin_system().registry.implementation("denoiser", args.denoiser).factory()
        blender = find_blender(args.blender)
        write_outputs(args.scene, blend, blender, args.render, args.engine, args.spp, args.width, denoiser)

    status = exit_status("psdr-room-blender", blend.parent, write)
    if status:
        return status
    print(f"Blender scene → {blend}" + (f" (render: {args.render})" if args.render else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
