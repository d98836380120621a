"""Denoising finished renders: the exported scenes of earlier runs rendered at each ``--spp``, as the path
tracer leaves them and through OIDN at each quality, against their photos (RMSE on 1/8-size images, SSIM,
ꟻLIP), with the denoiser's time per image.

    python benchmarks/denoiser.py outputs/real_photos/runs/*     # run folders: scene/scene.xml, artifacts/image/
    python benchmarks/denoiser.py RUN... --width 320 --spp 64 256
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.method.image_metrics import flip, rmse, ssim
from psdr_room_core.method.shading import linear_to_srgb
from psdr_room_plugins.denoisers import QUALITIES, OidnDenoiser
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer


def agreement(render: np.ndarray, photo: np.ndarray) -> tuple[float, float, float]:
    srgb = np.clip(linear_to_srgb(render), 0.0, 1.0)
    return rmse(srgb, photo), ssim(srgb, photo), flip(srgb, photo)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "runs", nargs="+", type=Path, help="run folders (scene/scene.xml and artifacts/image/image.png)"
    )
    parser.add_argument("--width", type=int, default=320, help="render width (height from the photo's aspect)")
    parser.add_argument("--spp", type=int, nargs="+", default=[64, 256], help="samples per pixel to compare")
    args = parser.parse_args()
    runs = [
        r for r in args.runs if (r / "scene" / "scene.xml").is_file() and (r / "artifacts/image/image.png").is_file()
    ]
    if not runs:
        sys.exit("denoiser.py: no run folder with scene/scene.xml and artifacts/image/image.png among the arguments")
    renderer, denoisers = MitsubaRenderer(), {q: OidnDenoiser(quality=q) for q in QUALITIES}
    for denoiser in denoisers.values():  # load the library and each filter before timing
        denoiser.denoise(np.zeros((16, 16, 3), np.float32))
    print(
        f"denoisers: {denoisers['high'].describe()} and its other qualities; metrics against the photo "
        "(RMSE 1/8 size, SSIM, FLIP), noisy → denoised (high)"
    )
    header = f"{'run':<26} {'spp':>4} {'RMSE':>13} {'SSIM':>13} {'FLIP':>13} " + " ".join(
        f"{q + ' s':>10}" for q in QUALITIES
    )
    print(header)
    print("-" * len(header))
    totals: dict[int, list[tuple[float, ...]]] = {spp: [] for spp in args.spp}
    for run in runs:
        photo8 = cv2.imread(str(run / "artifacts/image/image.png"))[..., ::-1]
        height = round(photo8.shape[0] * args.width / photo8.shape[1])
        photo = cv2.resize(photo8, (args.width, height), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
        for spp in args.spp:
            rgb, albedo, normal = renderer.render_file(
                run / "scene" / "scene.xml", spp, width=args.width, height=height
            )
            seconds, clean = {}, None
            for quality, denoiser in denoisers.items():
                start = time.perf_counter()
                out = denoiser.denoise(rgb, albedo, normal)
                seconds[quality] = time.perf_counter() - start
                clean = out if quality == "high" else clean
            before, after = agreement(rgb, photo), agreement(clean, photo)
            totals[spp].append(before + after)
            print(
                f"{run.name[:26]:<26} {spp:>4} "
                + " ".join(f"{b:.3f}→{a:.3f}".rjust(13) for b, a in zip(before, after))
                + " "
                + " ".join(f"{seconds[q]:10.2f}" for q in QUALITIES)
            )
    print("-" * len(header))
    for spp, rows in totals.items():
        m = np.median(np.array(rows), axis=0)
        better = [sum((r[k + 3] < r[k]) if k != 1 else (r[k + 3] > r[k]) for r in rows) for k in range(3)]
        print(
            f"{'median (' + str(len(rows)) + ' runs)':<26} {spp:>4} "
            + " ".join(f"{m[k]:.3f}→{m[k + 3]:.3f}".rjust(13) for k in range(3))
            + f"   denoised better: RMSE {better[0]}, SSIM {better[1]}, FLIP {better[2]} of {len(rows)}"
        )


if __name__ == "__main__":
    main()
