"""Relit check: exported scenes rendered as fitted and with one light moved, side by side. A scene whose materials
are plausible (walls of paint's albedo, low specular) stays a room when its light moves; one fitted with black,
mirror-like walls that only match the photo from its camera does not.

Each scene folder (e.g. the same photo's scene before and after a change to the fit) is rebuilt, its light
``--light`` (default: the brightest) is moved by ``--offset`` metres (world axes: y up), and both versions are
rendered by psdr-room's renderer (denoised). The sheet has a row per scene: photo-view render as fitted | with the
light moved; the table gives the walls' and ceiling's base-colour luminance and specular.

    python benchmarks/relit.py SCENE_DIR... [--light NAME] [--offset 1.5 0 0] [--labels A B] --out sheet.png
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.applications.edit import load_state, rebuild, render_folder
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.method.geometry import TriangleMesh
from psdr_room_core.method.material_priors import LUMINANCE, painted
from psdr_room_core.method.stages.export import scene_folder


def render(
    scene_dir: Path, light: str | None, offset: np.ndarray, spp: int
) -> tuple[np.ndarray, np.ndarray, str, list]:
    """(as fitted, light moved) sRGB renders of a scene folder, the moved light's name, and its walls' materials."""
    registry = plugin_system().registry
    library = registry.implementation("material_graph", "torch_graph").factory()
    renderer = registry.implementation("renderer", "mitsuba").factory()
    denoiser = registry.implementation("denoiser", "oidn").factory()
    state = load_state(scene_dir, library)
    scene = rebuild(scene_dir, state, library)
    name = light or max(scene.emitters, key=lambda n: float(np.mean(scene.emitters[n][1])))
    if name not in scene.emitters:
        raise PsdrRoomError(f"--light {name}: not a light of {scene_dir}; lights: {', '.join(scene.emitters)}")
    images = []
    for shift in (np.zeros(3), offset):
        mesh, radiance = scene.emitters[name]
        moved = dict(scene.emitters)
        moved[name] = (TriangleMesh(np.asarray(mesh.vertices) + shift, mesh.faces), radiance)
        with tempfile.TemporaryDirectory() as folder:
            files = scene_folder(replace(scene, emitters=moved), state, spp, 3, glb=False, usd=False)
            for path, data in files.items():
                (Path(folder) / path).parent.mkdir(parents=True, exist_ok=True)
                (Path(folder) / path).write_bytes(data)
            images.append(render_folder(Path(folder), spp, renderer, denoiser))
    walls = [
        (p["part"], float(np.dot(p["base_color"], LUMINANCE)), p["specular"])
        for p in state["parts"]
        if painted(p["part"])
    ]
    return images[0], images[1], name, walls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="+", type=Path, help="exported scene folders")
    parser.add_argument("--light", help="the light to move (default: each scene's brightest)")
    parser.add_argument("--offset", nargs=3, type=float, default=[1.5, 0.0, 0.0], metavar=("X", "Y", "Z"))
    parser.add_argument("--labels", nargs="+", help="a label per scene (default: the folder names)")
    parser.add_argument("--spp", type=int, default=128)
    parser.add_argument("--width", type=int, default=320, help="the sheet's image width")
    parser.add_argument("--out", type=Path, required=True, help="the sheet (PNG)")
    args = parser.parse_args()
    labels = args.labels or [s.parent.name for s in args.scenes]
    rows = []
    try:
        for scene, label in zip(args.scenes, labels):
            fitted, moved, name, walls = render(scene, args.light, np.asarray(args.offset), args.spp)
            print(f"{label}: {name} moved by {args.offset} m")
            for part, lum, spec in walls:
                print(f"  {part:<12} albedo (luminance) {lum:.3f}  specular {spec:.2f}")
            height = round(fitted.shape[0] * args.width / fitted.shape[1])
            pair = [cv2.resize(x, (args.width, height), interpolation=cv2.INTER_AREA) for x in (fitted, moved)]
            row = np.hstack(pair)
            cv2.putText(
                row,
                f"{label}: as fitted | {name} moved",
                (6, 18),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.5,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
            rows.append(row)
    except PsdrRoomError as exc:
        sys.exit(f"relit: {exc}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), np.vstack(rows)[..., ::-1])
    print(f"sheet: {args.out}")


if __name__ == "__main__":
    main()
