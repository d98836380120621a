"""renderer=mitsuba timing: forward + backward per iteration, a room box (6 quads) + 3 boxes + a ceiling light.

Rows: masks + depth + alpha (``render``; gradients to every vertex tensor), RGB for the appearance stage
(``render_rgb`` with ``prb``; gradients to base colour and light radiance), and RGB with vertex gradients
(``prb_projective``, ``rgb_sppi=0``; biased for flat-shaded meshes, for reference only). The first call
(Dr.Jit compilation; much less once ``~/.drjit`` holds the kernels) is reported apart from the median of the
following iterations. ``dr.sync_thread()`` runs before every clock read (LLVM kernels run asynchronously).

    python benchmarks/renderer.py [--sizes 160x120 320x240] [--iterations 10] [--spp 4] [--spp-boundary 16]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch

from psdr_room_core.method.artifacts import Camera, RoomBox
from psdr_room_core.method.geometry import TriangleMesh, box_mesh, quad_mesh
from psdr_room_core.method.rgb_scene import room_quads
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer

ROOM = RoomBox(
    camera_to_world=np.eye(4), center=np.array([0.0, 1.4, 0.0]), half_size=np.array([2.5, 1.4, 2.0]), yaw=0.0
)
BOXES = {  # name: (centre, half size, yaw)
    "table": ((0.6, 0.38, -0.8), (0.6, 0.38, 0.4), 0.0),
    "cabinet": ((1.8, 0.95, -1.7), (0.55, 0.95, 0.25), 0.0),
    "crate": ((-0.8, 0.25, 0.0), (0.3, 0.25, 0.3), 0.5),
}


def scene(width: int, height: int) -> tuple[Camera, np.ndarray, dict[str, TriangleMesh], dict[str, int]]:
    camera = Camera.from_vfov(width, height, 55.0)
    c2w = np.eye(4)
    pitch = np.radians(-10.0)
    c2w[:3, :3] = np.diag([1.0, -1.0, -1.0]) @ np.array(
        [[1, 0, 0], [0, np.cos(pitch), -np.sin(pitch)], [0, np.sin(pitch), np.cos(pitch)]]
    )
    c2w[:3, 3] = [0.0, 1.5, 1.8]
    meshes = {name: quad_mesh(quad) for name, quad in room_quads(ROOM).items()}
    parts = {name: {"floor": 1, "ceiling": 2}.get(name, 0) for name in meshes}
    for k, (name, (center, half, yaw)) in enumerate(BOXES.items()):
        c, s = np.cos(yaw), np.sin(yaw)
        meshes[name] = box_mesh(np.array(center), np.array(half), np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]))
        parts[name] = 3 + k
    return camera, c2w, meshes, parts


def timed(step, iterations: int) -> tuple[float, float]:
    import drjit as dr

    seconds = []
    for iteration in range(iterations + 1):
        dr.sync_thread()
        start = time.perf_counter()
        step(iteration)
        dr.sync_thread()
        seconds.append(time.perf_counter() - start)
    return seconds[0], statistics.median(seconds[1:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", nargs="+", default=["160x120", "320x240"])
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--spp-boundary", type=int, default=16)
    parser.add_argument("--rgb-spp", type=int, default=16)
    parser.add_argument("--max-depth", type=int, default=3)
    args = parser.parse_args()

    rows = []
    for size in args.sizes:
        width, height = (int(x) for x in size.split("x"))
        camera, c2w, meshes, parts = scene(width, height)
        light = quad_mesh(np.array([[-0.5, 2.75, -0.5], [0.5, 2.75, -0.5], [0.5, 2.75, 0.5], [-0.5, 2.75, 0.5]]))
        renderer = MitsubaRenderer(
            spp=args.spp,
            spp_boundary=args.spp_boundary,
            rgb_spp=args.rgb_spp,
            max_depth=args.max_depth,
            rgb_geometry_gradients=True,
        )
        geometry = renderer.geometry(camera, c2w, meshes, parts, emitters={"light": (light, (10.0, 10.0, 10.0))})
        base = {name: torch.tensor(mesh.vertices, dtype=torch.float32) for name, mesh in meshes.items()}
        offset = torch.zeros(3, requires_grad=True)
        target = torch.rand(geometry.n_parts, height, width, generator=torch.Generator().manual_seed(0))

        def masks_depth(iteration: int) -> None:
            vertices = {name: v + offset for name, v in base.items()}
            masks, depth, alpha = geometry.render(vertices, iteration)
            ((masks - target).abs().mean() + depth.mean() + alpha.mean()).backward()

        albedo = torch.full((len(meshes), 3), 0.5, requires_grad=True)
        radiance = torch.full((3,), 10.0, requires_grad=True)

        def rgb(iteration: int) -> None:
            image = geometry.render_rgb(
                base_color=dict(zip(meshes, albedo)), radiance={"light": radiance}, iteration=iteration
            )
            image.mean().backward()

        def rgb_geometry(iteration: int) -> None:
            vertices = {name: v + offset for name, v in base.items()}
            geometry.render_rgb(vertices, iteration=iteration).mean().backward()

        for label, step in (
            ("masks+depth (direct, projective)", masks_depth),
            ("rgb, albedo+light grads (prb)", rgb),
            ("rgb, vertex grads (prb_projective)", rgb_geometry),
        ):
            first, steady = timed(step, args.iterations)
            rows.append((size, label, first, steady))
            print(f"{size:>8}  {label:<36} first {first:7.2f} s   then {steady:6.3f} s/it", flush=True)

    print()
    print("| size | what | first call (JIT) s | s/iter (fwd+bwd) |")
    print("| --- | --- | --- | --- |")
    for size, label, first, steady in rows:
        print(f"| {size} | {label} | {first:.2f} | {steady:.3f} |")
    print(
        f"\n(spp {args.spp}, spp_boundary {args.spp_boundary}, rgb_spp {args.rgb_spp}, max_depth {args.max_depth}, "
        f"{len(BOXES)} boxes + 6 room quads, parts {3 + len(BOXES)})"
    )


if __name__ == "__main__":
    main()
