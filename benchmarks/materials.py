"""Material library benchmark: retrieval of library materials from transformed, relit crops with the offline
texture descriptor, the cost of graph evaluations and descriptor calls, and (``--fit``) how far fitting a
graph's parameters to a target made by the same graph cuts the descriptor loss.

Retrieval. The database is the ``assign_materials`` stage's :class:`~psdr_room_core.method.material_search.MaterialIndex`:
for every library material at its own parameter values, views of its appearance (``thumbnails.shade``, a fixed
light) at 3 scales × 3 rotations. Each query
is a crop of the same material with its continuous parameters perturbed (unconstrained u + N(0, σ)), under a
random light (direction, intensity, colour, ambient, exposure) and a random transform (scale, rotation
in [−45°, 90°], offset, crop aspect). A query's rank is that of its material when materials are sorted by
their nearest database crop; we report top-1 and top-5 accuracy over all queries, and the quantiles of the
best match's similarity, on which the stage's ``min_similarity`` is calibrated.

Flatness. The same queries' :func:`~psdr_room_core.method.surface_colours.texture_energy`, per material, beside
that of the room sides' crops of real photos run bare (``--real-runs``: a ``benchmarks/real_photos.py``
output's ``runs`` folder, crops as ``assign_materials`` chose them): the stage's ``flat_energy`` sits above
the real plain surfaces and the library's paints, plasters, glass and plastics, and below its wood, tiles,
stone, brick and carpets.

    python benchmarks/materials.py [--queries 4] [--sigma 0.5] [--fit] [--real-runs DIR] [--json out.json]

Timings are wall-clock seconds on this machine with ``torch.set_num_threads(--threads)`` (default 1).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import torch

from psdr_room_core.engine import shipped
from psdr_room_core.method.material_search import MaterialIndex
from psdr_room_core.method.surface_colours import texture_energy
from psdr_room_plugins.material_graph.library import TorchGraphLibrary
from psdr_room_plugins.material_graph.nodes.ops import sample_tiled
from psdr_room_plugins.material_graph.thumbnails import shade
from psdr_room_plugins.texture.random_cnn import RandomCnnDescriptor

CROP = 128


def timed(fn: Callable[[], object], repeat: int = 3) -> float:
    fn()  # warm-up (allocations, first-call overheads)
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def random_light(generator: torch.Generator) -> dict[str, object]:
    def uniform(lo: float, hi: float) -> float:
        return lo + (hi - lo) * float(torch.rand((), generator=generator))

    elevation = math.radians(uniform(25.0, 75.0))
    azimuth = uniform(0.0, 2 * math.pi)
    direction = (math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation))
    tint = uniform(-0.12, 0.12)
    return {
        "light": direction,
        "intensity": uniform(1.6, 3.6),
        "ambient": uniform(0.15, 0.5),
        "light_colour": (1.0 + tint, 1.0, 1.0 - tint),
        "exposure": uniform(0.75, 1.3),
    }


def retrieval(
    library: TorchGraphLibrary, descriptor: RandomCnnDescriptor, queries: int, sigma: float, map_size: int, seed: int
) -> dict[str, object]:
    generator = torch.Generator().manual_seed(seed)
    start = time.perf_counter()
    index = MaterialIndex.build(library, descriptor, map_size)
    db_seconds = time.perf_counter() - start
    names = index.names
    ranks: list[int] = []
    similarities: list[float] = []
    energies: dict[str, list[float]] = {}
    confusions: dict[str, list[str]] = {}
    start = time.perf_counter()
    with torch.no_grad():
        for number, name in enumerate(names):
            material = library.material(name)
            for _ in range(queries):
                params = {
                    k: v + sigma * torch.randn(v.shape, generator=generator)
                    for k, v in material.parameters(requires_grad=False).items()
                }
                light = random_light(generator)
                image = shade(material.evaluate(map_size, params), **light)  # type: ignore[arg-type]
                scale = math.exp(
                    math.log(0.6) + (math.log(2.5) - math.log(0.6)) * float(torch.rand((), generator=generator))
                )
                rotation = -45.0 + 135.0 * float(torch.rand((), generator=generator))
                aspect = 0.7 + 0.6 * float(torch.rand((), generator=generator))
                size = (CROP, max(64, round(CROP * aspect)))
                offset = (float(torch.rand((), generator=generator)), float(torch.rand((), generator=generator)))
                crop = sample_tiled(image, size, scale=scale, rotation_deg=rotation, offset=offset)
                energies.setdefault(name, []).append(texture_energy(crop.clamp(0, 1).permute(1, 2, 0).numpy()))
                distances = index.distances(descriptor, descriptor.describe(crop))
                order = torch.argsort(distances).tolist()
                rank = order.index(number)
                ranks.append(rank)
                similarities.append(index.similarity(float(distances[order[0]])))
                if rank:
                    confusions.setdefault(name, []).append(names[order[0]])
    query_seconds = time.perf_counter() - start
    per_material = {name: ranks[i * queries : (i + 1) * queries] for i, name in enumerate(names)}
    quantiles = {f"p{q}": float(np.percentile(similarities, q)) for q in (5, 10, 25, 50)}
    return {
        "materials": len(names),
        "queries": len(ranks),
        "top1": sum(r == 0 for r in ranks) / len(ranks),
        "top5": sum(r < 5 for r in ranks) / len(ranks),
        "worst": sorted(((sum(r == 0 for r in v) / len(v), n) for n, v in per_material.items()))[:8],
        "confusions": confusions,
        "database_s": db_seconds,
        "query_s": query_seconds,
        "similarity": quantiles,
        "spacing": index.spacing,
        "energy": {name: float(np.median(values)) for name, values in energies.items()},
    }


def real_energies(runs: Path) -> dict[str, list[float]]:
    """Texture energy of every room side's crop (floor, ceiling, walls) in each run under ``runs``, by side."""
    out: dict[str, list[float]] = {}
    for run in sorted(p for p in runs.iterdir() if (p / "artifacts" / "materials" / "materials.json").is_file()):
        rgb = cv2.imread(str(run / "artifacts" / "image" / "image.png"))[..., ::-1].astype(np.float32) / 255.0
        for part in json.loads((run / "artifacts" / "materials" / "materials.json").read_text())["parts"]:
            if not part["part"].startswith("object"):
                for x0, y0, x1, y1 in part["crops"]:
                    out.setdefault(part["part"].split("_")[0], []).append(texture_energy(rgb[y0:y1, x0:x1]))
    return out


def flatness_table(library_energy: dict[str, float], real: dict[str, list[float]], threshold: float) -> None:
    """Print the flatness calibration (see the module docstring)."""
    print(f"\n## Flatness (texture energy; assign_materials.flat_energy = {threshold:g})\n")
    print(
        "| population | crops | p10 | median | p90 | max | under flat_energy |\n| --- | --- | --- | --- | --- | --- | --- |"
    )
    rows = [("library materials (median of their queries)", list(library_energy.values()))]
    rows += [(f"real photos: {side} crops", values) for side, values in sorted(real.items())]
    for label, values in rows:
        q = np.percentile(values, [10, 50, 90])
        print(
            f"| {label} | {len(values)} | {q[0]:.3f} | {q[1]:.3f} | {q[2]:.3f} | {max(values):.3f} | "
            f"{sum(v < threshold for v in values)}/{len(values)} |"
        )
    plain = sorted((v, n) for n, v in library_energy.items() if v < threshold)
    print("Library materials a flat colour stands in for: " + ", ".join(f"{n} {v:.3f}" for v, n in plain))
    textured = sorted((v, n) for n, v in library_energy.items() if v >= threshold)[:6]
    print("Least textured of the rest: " + ", ".join(f"{n} {v:.3f}" for v, n in textured))


def timings(library: TorchGraphLibrary, descriptor: RandomCnnDescriptor) -> dict[str, object]:
    rows: dict[str, dict[str, float]] = {}
    for name in library.names():
        material = library.material(name)
        row = {}
        for size in (256, 512):
            with torch.no_grad():
                row[f"eval_{size}"] = timed(lambda: material.evaluate(size), repeat=2)
            params = material.parameters()

            def forward_backward() -> None:
                maps = material.evaluate(size, params)
                if params:
                    sum(m.sum() for m in maps.values()).backward()

            row[f"grad_{size}"] = timed(forward_backward, repeat=1)
        rows[name] = row
    desc: dict[str, float] = {}
    for size in (128, 256, 512):
        image = torch.rand(3, size, size)
        with torch.no_grad():
            desc[f"describe_{size}"] = timed(lambda: descriptor.describe(image))
        leaf = image.clone().requires_grad_(True)
        desc[f"grad_{size}"] = timed(lambda: descriptor.describe(leaf).sum().backward())
    return {"graphs": rows, "descriptor": desc}


def fit(
    library: TorchGraphLibrary, descriptor: RandomCnnDescriptor, size: int, iterations: int, seed: int
) -> dict[str, float]:
    """Loss reduction (1 − final/initial) of Adam on each graph's parameters towards the same graph shaded at
    random other parameters (as tests/test_material_graphs.py does for three graphs)."""
    out = {}
    for name in library.names():
        material = library.material(name)
        start = material.parameters()
        if not start:
            continue
        generator = torch.Generator().manual_seed(seed)
        with torch.no_grad():
            other = {k: v + torch.randn(v.shape, generator=generator) for k, v in start.items()}
            target = descriptor.describe(shade(material.evaluate(size, other)))
        optimiser = torch.optim.Adam(list(start.values()), lr=0.1)
        first = last = 0.0
        for i in range(iterations):
            optimiser.zero_grad()
            loss = descriptor.distance(descriptor.describe(shade(material.evaluate(size, start))), target)
            loss.backward()
            optimiser.step()
            first = float(loss.detach()) if i == 0 else first
            last = float(loss.detach())
        out[name] = 1.0 - last / max(first, 1e-12)
        print(f"  fit {name}: {first:.4f} -> {last:.4f} ({out[name]:.0%})", flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--queries", type=int, default=4, help="queries per material")
    parser.add_argument("--sigma", type=float, default=0.5, help="std of the parameter perturbation (unconstrained)")
    parser.add_argument("--map-size", type=int, default=256)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--no-timings", action="store_true")
    parser.add_argument("--fit", action="store_true", help="also fit every graph to a target made by itself")
    parser.add_argument("--fit-size", type=int, default=96)
    parser.add_argument("--fit-iterations", type=int, default=100)
    parser.add_argument("--real-runs", type=Path, help="runs/ of a real_photos.py output: calibrate flatness on it")
    parser.add_argument("--json", default=None, help="write the results to this JSON file")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    library = TorchGraphLibrary(use_plugins=False)
    descriptor = RandomCnnDescriptor()
    results: dict[str, object] = {}

    r = retrieval(library, descriptor, args.queries, args.sigma, args.map_size, args.seed)
    results["retrieval"] = r
    print(f"\n## Retrieval (texture=random_cnn, {r['materials']} materials, {r['queries']} queries, σ={args.sigma})\n")
    print("| top-1 | top-5 | database (s) | per query (s) |\n| --- | --- | --- | --- |")
    print(f"| {r['top1']:.1%} | {r['top5']:.1%} | {r['database_s']:.1f} | {r['query_s'] / r['queries']:.3f} |")
    print("\nWorst top-1 per material: " + ", ".join(f"{n} {a:.0%}" for a, n in r["worst"]))  # type: ignore[union-attr]
    q = r["similarity"]  # type: ignore[index]
    print(
        f"Similarity of each query's best match (1 − d / library spacing {r['spacing']:.4f}): "
        + ", ".join(f"{k} {v:.3f}" for k, v in q.items())
        + " (assign_materials.min_similarity is calibrated on p10)"
    )
    print("Confused with: " + "; ".join(f"{k} -> {', '.join(v)}" for k, v in r["confusions"].items()))  # type: ignore[union-attr]
    real = real_energies(args.real_runs) if args.real_runs else {}
    results["real_energy"] = real
    flat_energy = float(shipped.node("assign_materials.flat_energy"))
    flatness_table(r["energy"], real, flat_energy)  # type: ignore[arg-type]

    if not args.no_timings:
        t = timings(library, descriptor)
        results["timings"] = t
        graphs = t["graphs"]  # type: ignore[index]
        print(f"\n## Graph evaluation, seconds ({len(graphs)} graphs, {args.threads} thread(s))\n")
        print("| | median | mean | max (graph) |\n| --- | --- | --- | --- |")
        for key, label in (
            ("eval_256", "evaluate 256²"),
            ("eval_512", "evaluate 512²"),
            ("grad_256", "evaluate + backward 256²"),
            ("grad_512", "evaluate + backward 512²"),
        ):
            values = {n: row[key] for n, row in graphs.items()}
            worst = max(values, key=values.get)
            print(
                f"| {label} | {statistics.median(values.values()):.3f} | {statistics.mean(values.values()):.3f} | "
                f"{values[worst]:.3f} ({worst}) |"
            )
        d = t["descriptor"]  # type: ignore[index]
        print("\n## Descriptor call (texture=random_cnn, crops resized to 256 on their shorter side), seconds\n")
        print("| crop | describe | describe + backward |\n| --- | --- | --- |")
        for size in (128, 256, 512):
            print(f"| {size}² | {d[f'describe_{size}']:.3f} | {d[f'grad_{size}']:.3f} |")

    if args.fit:
        f = fit(library, descriptor, args.fit_size, args.fit_iterations, args.seed)
        results["fit"] = f
        below = sorted((v, n) for n, v in f.items() if v < 0.8)
        print(f"\n## Fit to a target made by the same graph ({args.fit_size}², {args.fit_iterations} Adam steps)\n")
        print(
            f"median loss reduction {statistics.median(f.values()):.1%}, min {min(f.values()):.1%}; "
            f"{len(f) - len(below)}/{len(f)} graphs ≥ 80%"
            + (": below: " + ", ".join(f"{n} {v:.0%}" for v, n in below) if below else "")
        )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=1, default=str)


if __name__ == "__main__":
    main()
