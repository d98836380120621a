"""The exported scene opened by the programs its users open it with: Mitsuba, Blender (Cycles and EEVEE), USD.

For each run (default: the README example and two shared photos, run bare with default settings into
``OUT/runs`` unless a finished run is there), the scene folder is

* rendered by psdr-room's own renderer (``scene.xml`` through the renderer plugin, denoised: what
  ``psdr-room-edit`` writes as ``render.png``), the reference, downsampled to 320 px wide;
* loaded with a plain ``mitsuba.load_file`` (default optimisations): the parts and lights of ``appearance.json``
  that ``mi.traverse`` reaches by id, and a 320 px wide render (``--mitsuba-spp``, not denoised);
* built and rendered 320 px wide by ``psdr-room-blender`` with Cycles (``--cycles-spp``; as Cycles rendered it,
  and cleaned by the same denoiser as the reference, which ``psdr-room-blender --render`` does by default) and
  EEVEE;
* opened with ``usd-core``: ``pxr.UsdValidation``'s errors on ``scene.usda`` (all registered validators), and the
  meshes, materials and lights read back against ``appearance.json``.

It prints SSIM and the mean-luminance ratio of each render against the reference, and writes a contact sheet
per run (photo | psdr-room | Mitsuba | Cycles (denoised) | EEVEE | relit: psdr-room's render with the brightest light moved
1.5 m along x, ``relit.py``) to ``OUT/sheets/<run>.png``.

    python benchmarks/interchange.py [--runs RUN_DIR ...] [--out DIR] [--cycles-spp 128]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from relit import render as relit  # sibling benchmark

from psdr_room_core.applications.blender import build_blend, denoise_png, find_blender
from psdr_room_core.applications.edit import render_folder
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.method.image_metrics import ssim
from psdr_room_core.method.material_priors import LUMINANCE
from psdr_room_core.method.shading import linear_to_srgb

REPO = Path(__file__).resolve().parents[1]
PHOTOS = REPO.parent / "shared" / "data" / "photos"
DEFAULT_PHOTOS = (
    REPO / "examples" / "nyu_basement" / "photo.jpg",
    PHOTOS / "sunrgbd_total3d_05" / "img.jpg",
    PHOTOS / "nyu_metric3d_00000" / "rgb_00000.jpg",
)
"""The example and two shared photos (a bedroom, a living room)."""
OUT = REPO / "outputs" / "benchmarks" / "interchange"
WIDTH = 320
"""Every render is compared at this width (the photo's aspect kept: 320×240 for a 4:3 photo)."""


def run_photo(photo: Path, run_dir: Path, cache: Path) -> Path:
    """A bare run of ``photo`` (copied alone into a folder) into ``run_dir``, unless one finished there."""
    if (run_dir / "scene" / "scene.usda").is_file():
        return run_dir
    if run_dir.exists():
        shutil.rmtree(run_dir)
    with tempfile.TemporaryDirectory() as bare:
        alone = Path(bare) / photo.name
        shutil.copyfile(photo, alone)
        command = [
            shutil.which("psdr-room") or "psdr-room",
            f"image={alone}",
            f"hydra.run.dir={run_dir}",
            f"cache_dir={cache}",
        ]
        result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"interchange: {photo} failed: {result.stderr.strip().splitlines()[-1:]}")
    return run_dir


def load_rgb(path: Path) -> np.ndarray:
    return cv2.imread(str(path))[..., ::-1].astype(np.float64) / 255.0


def fit(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA) if image.shape[1::-1] != size else image


def luminance(image: np.ndarray) -> float:
    return float((image @ np.array(LUMINANCE)).mean())


def mitsuba_check(scene: Path, state: dict, spp: int, size: tuple[int, int]) -> tuple[np.ndarray, int, int]:
    """A plain user's load of ``scene.xml``: its render at ``size`` (sRGB), and the parts and lights reached by id."""
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    loaded = mi.load_file(str(scene / "scene.xml"), width=size[0], height=size[1], spp=spp)
    keys = set(mi.traverse(loaded).keys())
    lamp_parts = {light["part"] for light in state["lights"] if light["part"]}
    wanted = ({p["part"] for p in state["parts"]} - lamp_parts) | {light["name"] for light in state["lights"]}
    wanted |= set(state["fixtures"])
    reached = sum(f"{name}.vertex_positions" in keys for name in wanted)
    return linear_to_srgb(np.array(mi.render(loaded, spp=spp))), reached, len(wanted)


def usd_check(scene: Path, state: dict) -> dict:
    """``scene.usda`` opened, validated and read back."""
    from pxr import Usd, UsdGeom, UsdLux, UsdShade, UsdValidation

    stage = Usd.Stage.Open(str(scene / "scene.usda"))
    registry = UsdValidation.ValidationRegistry()
    errors = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators()).Validate(stage)
    prims = list(stage.Traverse())
    lights = {p.GetName() for p in prims if p.HasAPI(UsdLux.LightAPI) or p.IsA(UsdLux.BoundableLightBase)}
    meshes = {p.GetName() for p in prims if p.IsA(UsdGeom.Mesh)} - lights
    materials = {p.GetName() for p in prims if p.IsA(UsdShade.Material)}
    lamp_parts = {light["part"] for light in state["lights"] if light["part"]}
    parts = ({p["part"] for p in state["parts"]} - lamp_parts) | set(state["fixtures"])
    return {
        "errors": [e.GetMessage() for e in errors],
        "meshes": f"{len(meshes & parts)}/{len(parts)}",
        "materials": f"{len(materials & parts)}/{len(parts)}",
        "lights": f"{len(lights & {light['name'] for light in state['lights']})}/{len(state['lights'])}",
        "up": UsdGeom.GetStageUpAxis(stage),
        "metres": UsdGeom.GetStageMetersPerUnit(stage),
    }


def evaluate(run_dir: Path, out: Path, blender: str, cycles_spp: int, mitsuba_spp: int) -> dict:
    """One run's row and contact sheet."""
    scene = run_dir / "scene"
    state = json.loads((scene / "appearance.json").read_text())
    registry = plugin_system().registry
    renderer = registry.implementation("renderer", "mitsuba").factory()
    denoiser = registry.implementation("denoiser", "oidn").factory()
    size = (WIDTH, round(WIDTH * state["camera"]["height"] / state["camera"]["width"]))
    reference = fit(render_folder(scene, 256, renderer, denoiser).astype(np.float64) / 255.0, size)
    mitsuba, reached, parts = mitsuba_check(scene, state, mitsuba_spp, size)
    renders = {"mitsuba": mitsuba}
    work = out / "blender" / run_dir.name
    for engine, spp in (("cycles", cycles_spp), ("eevee", 64)):
        png = work / f"{engine}.png"
        build_blend(scene, work / f"scene_{engine}.blend", blender, png, engine, spp, WIDTH)
        renders[engine] = load_rgb(png)
        if engine == "cycles":
            clean = work / "cycles_denoised.png"
            shutil.copyfile(png, clean)
            denoise_png(clean, denoiser)
            renders["cycles_denoised"] = load_rgb(clean)
    row = {"run": run_dir.name, "parts": f"{reached}/{parts}", "usd": usd_check(scene, state)}
    for name, image in renders.items():
        row[name] = {"ssim": ssim(image, reference), "luminance": luminance(image) / luminance(reference)}
    photo = fit(load_rgb(run_dir / "artifacts" / "image" / "image.png"), size)
    moved = fit(relit(scene, None, np.array([1.5, 0.0, 0.0]), 128)[1].astype(np.float64) / 255.0, size)
    shown = ("mitsuba", "cycles_denoised", "eevee")
    sheet = np.hstack([photo, reference, *(renders[k] for k in shown), moved])
    (out / "sheets").mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out / "sheets" / f"{run_dir.name}.png"), (sheet[..., ::-1] * 255 + 0.5).astype(np.uint8))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--runs",
        nargs="+",
        type=Path,
        help="finished run folders (default: run the example and two shared photos into OUT/runs)",
    )
    parser.add_argument("--out", type=Path, default=OUT, help="runs, Blender files, sheets (default: %(default)s)")
    parser.add_argument("--cycles-spp", type=int, default=128)
    parser.add_argument("--mitsuba-spp", type=int, default=256)
    parser.add_argument("--blender", help="the Blender executable (default: $PSDR_ROOM_BLENDER or blender)")
    args = parser.parse_args()
    try:
        blender = find_blender(args.blender)
    except PsdrRoomError as exc:
        sys.exit(f"interchange: {exc}")
    cache = (args.out / "cache").resolve()
    os.environ.setdefault("PSDR_ROOM_CACHE_DIR", str(cache))
    runs = args.runs or [run_photo(p, args.out / "runs" / p.parent.name, cache) for p in DEFAULT_PHOTOS]
    rows = []
    for run_dir in runs:
        rows.append(evaluate(run_dir, args.out, blender, args.cycles_spp, args.mitsuba_spp))
        print(f"{run_dir.name}: done", file=sys.stderr, flush=True)
    print(
        f"Exported scenes in other programs, {WIDTH} px wide, against psdr-room's own render (SSIM, luminance ratio)\n"
    )
    header = (
        f"{'run':<22} {'Mitsuba ids':>11} {'Mitsuba':>14} {'Cycles':>14} {'Cycles denoised':>15} {'EEVEE':>14} "
        f"{'USD errors':>10} {'meshes':>7} {'materials':>9} {'lights':>6}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        cells = " ".join(
            f"{r[k]['ssim']:.3f} {r[k]['luminance']:.2f}x".rjust(width)
            for k, width in (("mitsuba", 14), ("cycles", 14), ("cycles_denoised", 15), ("eevee", 14))
        )
        usd = r["usd"]
        print(
            f"{r['run']:<22} {r['parts']:>11} {cells} {len(usd['errors']):>10} {usd['meshes']:>7} "
            f"{usd['materials']:>9} {usd['lights']:>6}"
        )
        for message in usd["errors"][:5]:
            print(f"  USD: {message}")
    print(
        f"\n(USD stages: up axis {', '.join(sorted({r['usd']['up'] for r in rows}))}, metres per unit "
        f"{', '.join(sorted({str(r['usd']['metres']) for r in rows}))}; Cycles {args.cycles_spp} spp and Mitsuba "
        f"{args.mitsuba_spp} spp, not denoised, and Cycles denoised by oidn as the reference is; EEVEE 64 samples)"
    )
    print(
        f"contact sheets (photo | psdr-room | Mitsuba | Cycles denoised | EEVEE | relit): {args.out / 'sheets'}/<run>.png"
    )


if __name__ == "__main__":
    main()
