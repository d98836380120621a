"""renderer=mitsuba: LLVM lookup, exact forward masks/depth, and gradients against finite differences.

The gradient checks use the path the stages use: parameters → vertex tensors in torch → masks/depth/RGB
from the renderer → a loss, differentiated by ``backward()``; the reference is central finite differences
of the same loss with common random numbers (the same iteration seed for +h and −h) at many samples per
pixel. Criterion: relative error below 10% on the three largest components, and the same sign wherever
the finite difference is not noise (above 10% of the largest component). Tiny resolutions keep the whole
module under a minute on two cores (the first render pays Dr.Jit's compilation, cached in ~/.drjit).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.engine import shipped
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.settings import check_settings
from psdr_room_core.libraries.llvm import ensure_llvm, find_llvm, llvm_version
from psdr_room_core.method.artifacts import Camera, RoomBox
from psdr_room_core.method.geometry import TriangleMesh, box_mesh, quad_mesh
from psdr_room_core.method.shading import Surface
from psdr_room_plugins.mitsuba_renderer.session import weld_map
from psdr_room_plugins.mitsuba_renderer.settings import MitsubaSettings


# ------------------------------------------------------------------------------------------ LLVM lookup
def _touch(path: Path) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"")
    return str(path)


def test_llvm_version_from_names() -> None:
    assert llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1") == 19
    assert llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1") == 15
    assert llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM-14.0.6.so.1") == 14
    assert llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM-19.so") == 19
    assert llvm_version("/usr/lib/llvm-18/lib/libLLVM.so") == 18
    assert llvm_version("/usr/lib/llvm-14/lib/libLLVMCore.a") is None
    assert llvm_version("/usr/lib/llvm-14/lib/libLLVMCore.so") is None


def test_llvm_locator_picks_16_or_newer(tmp_path: Path) -> None:
    _touch(tmp_path / "x86_64-linux-gnu" / "libLLVM-15.so.1")
    _touch(tmp_path / "x86_64-linux-gnu" / "libLLVM-14.so.1")
    new = _touch(tmp_path / "x86_64-linux-gnu" / "libLLVM.so.19.1")
    _touch(tmp_path / "llvm-14" / "lib" / "libLLVMCore.a")
    patterns = [str(tmp_path / "*" / "libLLVM*.so*"), str(tmp_path / "llvm-*" / "lib" / "libLLVM*.so*")]
    best, candidates = find_llvm(patterns)
    assert best == new and {v for v, _ in candidates} == {14, 15, 19}
    env: dict[str, str] = {}
    assert ensure_llvm(patterns, environ=env) == new and env["DRJIT_LIBLLVM_PATH"] == new
    # An existing DRJIT_LIBLLVM_PATH to a file is respected; a stale one (missing file) is replaced.
    other = _touch(tmp_path / "custom" / "libLLVM.so.17")
    assert ensure_llvm(patterns, environ={"DRJIT_LIBLLVM_PATH": other}) == other
    env = {"DRJIT_LIBLLVM_PATH": str(tmp_path / "gone" / "libLLVM.so.19")}
    assert ensure_llvm(patterns, environ=env) == new


def test_llvm_locator_names_the_package_when_only_old_ones(tmp_path: Path) -> None:
    _touch(tmp_path / "x86_64-linux-gnu" / "libLLVM-15.so.1")
    _touch(tmp_path / "llvm-14" / "lib" / "libLLVM.so")
    patterns = [str(tmp_path / "*" / "libLLVM*.so*"), str(tmp_path / "llvm-*" / "lib" / "libLLVM*.so*")]
    with pytest.raises(PsdrRoomError, match="apt-get install libllvm19") as info:
        ensure_llvm(patterns, environ={})
    assert "LLVM 15" in str(info.value) and "LLVM 14" in str(info.value)
    with pytest.raises(PsdrRoomError, match="libllvm19"):
        ensure_llvm([str(tmp_path / "nothing" / "*.so")], environ={})
    with pytest.raises(PsdrRoomError, match="libllvm19"):
        ensure_llvm(patterns, environ={"DRJIT_LIBLLVM_PATH": _touch(tmp_path / "old" / "libLLVM-15.so")})


def test_weld_map_merges_split_vertices() -> None:
    split = box_mesh(np.zeros(3), np.ones(3))
    faces = split.faces
    soup = TriangleMesh(split.vertices[faces.reshape(-1)], np.arange(faces.size).reshape(-1, 3))
    first, welded = weld_map(soup)
    assert len(first) == 8 and len(welded) == 12
    assert np.allclose(np.sort(soup.vertices[first], axis=0), np.sort(split.vertices, axis=0))


def test_factory_is_cheap_and_validates() -> None:
    import sys

    from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer

    was_loaded = "mitsuba" in sys.modules
    MitsubaRenderer(spp=2, spp_boundary=2)
    assert was_loaded or "mitsuba" not in sys.modules
    with pytest.raises(PsdrRoomError, match="^renderer.mitsuba.spp=0 is out of range"):  # the schema checks it
        check_settings(MitsubaSettings, {**shipped.node("renderer.mitsuba"), "spp": 0}, "renderer.mitsuba")
    with pytest.raises(PsdrRoomError, match="variant"):
        _ = MitsubaRenderer(variant="vulkan").variant


# ----------------------------------------------------------------------------------------- rendering
torch = pytest.importorskip("torch")


@pytest.fixture(scope="module")
def renderer_cls():
    from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer

    try:
        MitsubaRenderer().activate()
    except PsdrRoomError as exc:  # no usable LLVM on this machine
        pytest.skip(str(exc))
    return MitsubaRenderer


def _rotation(yaw: float, pitch: float) -> np.ndarray:
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    return np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]) @ np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])


def test_forward_masks_and_depth_are_exact(renderer_cls) -> None:
    """A fronto-parallel quad at z = 2 covering u >= 40, v >= 30 (pixel edges) under an off-centre principal
    point and a rotated, translated camera: coverage is exactly 0/1, depth exactly 2; moved by half a
    pixel, the boundary column is half covered."""
    f = 40.0
    camera = Camera(width=64, height=48, fx=f, fy=f, cx=36.0, cy=20.0)
    c2w = np.eye(4)
    c2w[:3, :3] = _rotation(0.4, -0.2) @ np.diag([1.0, -1.0, -1.0])  # some pose; camera axes in OpenCV convention
    c2w[:3, 3] = [0.5, 1.2, -0.3]

    def quad(u0: float, v0: float) -> TriangleMesh:
        z = 2.0
        x0, y0 = (u0 - camera.cx) * z / f, (v0 - camera.cy) * z / f
        corners = np.array([[x0, y0, z], [9.0, y0, z], [9.0, 9.0, z], [x0, 9.0, z]])
        return quad_mesh(corners @ c2w[:3, :3].T + c2w[:3, 3])

    renderer = renderer_cls(spp=64, spp_boundary=4)
    masks, depth, alpha = renderer.geometry(camera, c2w, {"quad": quad(40.0, 30.0)}, {"quad": 0}).render()
    expected = np.zeros((48, 64))
    expected[30:, 40:] = 1.0
    assert masks.shape == (1, 48, 64) and depth.shape == (48, 64) and alpha.shape == (48, 64)
    np.testing.assert_allclose(masks[0].numpy(), expected, atol=1e-6)
    np.testing.assert_allclose(alpha.numpy(), expected, atol=1e-6)
    np.testing.assert_allclose(depth.numpy(), 2.0 * expected, atol=1e-4)

    renderer = renderer_cls(spp=1024, spp_boundary=4)
    masks, depth, _ = renderer.geometry(camera, c2w, {"quad": quad(40.5, 30.0)}, {"quad": 0}).render()
    column = masks[0, 35:, 40].numpy()
    assert np.all(np.abs(column - 0.5) < 0.06), column
    np.testing.assert_allclose(masks[0, 35:, 41:].numpy(), 1.0, atol=1e-6)
    np.testing.assert_allclose(masks[0, :, :40].numpy(), 0.0, atol=1e-6)
    np.testing.assert_allclose(depth[35:, 40].numpy(), 2.0 * column, rtol=1e-4)


# ------------------------------------------------------------------- gradient checks: room + box object
W, H = 64, 48
ROOM = RoomBox(
    camera_to_world=np.eye(4), center=np.array([0.0, 1.5, 0.0]), half_size=np.array([2.0, 1.5, 2.5]), yaw=0.0
)
OBJECT = (np.array([0.3, 0.6, -0.6]), np.array([0.45, 0.35, 0.3]), 0.35)  # centre, half size, yaw (floating)
PARTS = {"wall_x_neg": 0, "wall_x_pos": 0, "wall_z_neg": 0, "wall_z_pos": 0, "floor": 1, "ceiling": 2, "object": 3}
PARAMS = ["tx", "ty", "tz", "yaw", "log_scale", "log_scale_x", "log_scale_y", "log_scale_z", "wall_x", "ceiling"]
TARGET = np.array([0.05, -0.03, 0.04, 0.05, 0.03, 0.02, -0.03, 0.02, -0.06, 0.05])


def _camera() -> tuple[Camera, np.ndarray]:
    """Looking along -z from inside the room, turned and rolled a little so that no edge is pixel-aligned
    (a central difference across an edge that lies on a pixel boundary is not a derivative)."""
    roll = np.radians(4.0)
    rz = np.array([[np.cos(roll), -np.sin(roll), 0], [np.sin(roll), np.cos(roll), 0], [0, 0, 1]])
    c2w = np.eye(4)
    c2w[:3, :3] = _rotation(np.radians(6.0), 0.0) @ np.diag([1.0, -1.0, -1.0]) @ _rotation(0.0, np.radians(-5.0)) @ rz
    c2w[:3, 3] = [0.2, 1.4, 2.0]
    return Camera.from_vfov(W, H, 60.0), c2w


def _vertices(theta: torch.Tensor) -> dict[str, torch.Tensor]:
    """The scene's vertex tensors as a function of the 10 parameters (float64 in, float32 out)."""
    from psdr_room_core.method.rgb_scene import room_quad_indices

    signs = torch.tensor([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=torch.float64) * 2 - 1
    zero = torch.zeros((), dtype=torch.float64)
    lo = torch.tensor(ROOM.center - ROOM.half_size)
    hi = torch.tensor(ROOM.center + ROOM.half_size) + torch.stack([theta[8], theta[9], zero])
    corners = torch.where(signs > 0, hi, lo)
    out = {name: corners[torch.as_tensor(index.copy())].float() for name, index in room_quad_indices(ROOM).items()}
    center, half, yaw0 = OBJECT
    size = torch.tensor(half) * torch.exp(theta[4] + theta[5:8])
    c, s = torch.cos(yaw0 + theta[3]), torch.sin(yaw0 + theta[3])
    one = torch.ones((), dtype=torch.float64)
    rotation = torch.stack([torch.stack([c, zero, s]), torch.stack([zero, one, zero]), torch.stack([-s, zero, c])])
    out["object"] = (torch.tensor(center) + theta[0:3] + (signs * size) @ rotation.T).float()
    return out


def _meshes() -> dict[str, TriangleMesh]:
    v = {k: t.numpy().astype(np.float64) for k, t in _vertices(torch.zeros(10, dtype=torch.float64)).items()}
    meshes = {name: quad_mesh(quad) for name, quad in v.items() if name != "object"}
    meshes["object"] = TriangleMesh(v["object"], box_mesh(np.zeros(3), np.ones(3)).faces)
    return meshes


def _check(name: str, ad: np.ndarray, fd: np.ndarray, labels: list[str]) -> None:
    table = "\n".join(f"  {p:>12}: AD {a: .5g}  FD {f: .5g}" for p, a, f in zip(labels, ad, fd))
    print(f"{name}\n{table}")  # shown with pytest -s
    scale = np.abs(fd).max()
    assert scale > 0, f"{name}: finite differences are all zero\n{table}"
    for k in np.argsort(-np.abs(fd))[:3]:
        assert abs(ad[k] - fd[k]) < 0.1 * abs(fd[k]), f"{name}: {labels[k]} off by more than 10%\n{table}"
    significant = np.abs(fd) > 0.1 * scale
    assert np.all(np.sign(ad[significant]) == np.sign(fd[significant])), f"{name}: sign mismatch\n{table}"


def _soft_iou_loss(masks: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    inter = (masks * target).sum((1, 2))
    union = (masks + target - masks * target).sum((1, 2))
    return (1.0 - inter / union).sum()


def test_mask_and_depth_gradients_match_finite_differences(renderer_cls) -> None:
    camera, c2w = _camera()
    meshes = _meshes()
    with torch.no_grad():
        target = (
            renderer_cls(spp=256)
            .geometry(camera, c2w, meshes, PARTS)
            .render(_vertices(torch.tensor(TARGET)), iteration=12345)
        )
    renderer = renderer_cls(spp=64, spp_boundary=256).geometry(camera, c2w, meshes, PARTS)
    assert renderer.n_parts == 4
    # A target depth off by a scale and offset, as a monocular estimate is: per-pixel residuals then stay
    # away from 0, where the L1 kink would make the comparison test the loss's noise, not the renderer.
    target_depth = 1.1 * target[1] + 0.05

    def losses(theta: torch.Tensor, iteration: int, geometry=renderer) -> tuple[torch.Tensor, torch.Tensor]:
        masks, depth, _ = geometry.render(_vertices(theta), iteration)
        return _soft_iou_loss(masks, target[0]), (depth - target_depth).abs().mean()

    ad_mask, ad_depth = np.zeros(10), np.zeros(10)
    runs = 3
    for iteration in range(runs):
        theta = torch.zeros(10, dtype=torch.float64, requires_grad=True)
        mask_loss, depth_loss = losses(theta, iteration)
        ad_mask += torch.autograd.grad(mask_loss, theta, retain_graph=True)[0].numpy() / runs
        ad_depth += torch.autograd.grad(depth_loss, theta)[0].numpy() / runs

    fine = renderer_cls(spp=4096).geometry(camera, c2w, meshes, PARTS)
    fd_mask, fd_depth, h = np.zeros(10), np.zeros(10), 0.01
    with torch.no_grad():
        for i in range(10):
            step = torch.zeros(10, dtype=torch.float64)
            step[i] = h
            plus, minus = losses(step, 7, fine), losses(-step, 7, fine)  # common random numbers
            fd_mask[i] = float(plus[0] - minus[0]) / (2 * h)
            fd_depth[i] = float(plus[1] - minus[1]) / (2 * h)
    _check("mask soft-IoU", ad_mask, fd_mask, PARAMS)
    _check("depth L1", ad_depth, fd_depth, PARAMS)
    # The room's own parameters must carry mask gradient too (its creases between separate quads).
    assert abs(ad_mask[8]) > 0.05 * np.abs(fd_mask).max() and abs(ad_mask[9]) > 0.05 * np.abs(fd_mask).max()


def _rgb_geometry(renderer_cls, surfaces=None, **params):
    camera, c2w = _camera()
    light = quad_mesh(np.array([[-0.4, 2.95, -0.4], [0.4, 2.95, -0.4], [0.4, 2.95, 0.4], [-0.4, 2.95, 0.4]]))
    albedo = {name: (0.6, 0.6, 0.6) for name in PARTS} | {"object": (0.8, 0.3, 0.2), "floor": (0.5, 0.45, 0.4)}
    surfaces = {name: Surface(base_color=rgb) for name, rgb in albedo.items()} | dict(surfaces or {})
    return renderer_cls(max_depth=3, **params).geometry(
        camera, c2w, _meshes(), PARTS, surfaces=surfaces, emitters={"light": (light, (8.0, 8.0, 8.0))}
    )


def test_rgb_gradients_match_finite_differences(renderer_cls) -> None:
    """Path-traced RGB (global illumination, max_depth 3), differentiable in albedo and emitter radiance."""
    import torch.nn.functional as F

    def pooled(image: torch.Tensor) -> torch.Tensor:  # a 1/8-resolution image loss, as the paper's
        return F.avg_pool2d(image.permute(2, 0, 1)[None], 8)

    names = ["object", "floor", "wall_z_neg"]
    labels = [f"{n}.{c}" for n in names for c in "rgb"] + ["light.r", "light.g", "light.b"]
    base = torch.tensor([[0.8, 0.3, 0.2], [0.5, 0.45, 0.4], [0.6, 0.6, 0.6], [8.0, 8.0, 8.0]], dtype=torch.float64)
    with torch.no_grad():
        goal = base * torch.tensor([[0.7, 1.4, 1.2], [1.3, 1.0, 0.8], [0.9, 1.1, 1.2], [1.2, 0.9, 1.0]])
        target = pooled(
            _rgb_geometry(renderer_cls, rgb_spp=256).render_rgb(
                base_color=dict(zip(names, goal[:3])), radiance={"light": goal[3]}, iteration=999
            )
        )
    renderer = _rgb_geometry(renderer_cls, rgb_spp=64)

    def loss(x: torch.Tensor, iteration: int, geometry=renderer) -> torch.Tensor:
        image = geometry.render_rgb(
            base_color=dict(zip(names, x[:3].float())), radiance={"light": x[3].float()}, iteration=iteration
        )
        return ((pooled(image) - target) ** 2).mean()

    x = base.clone().requires_grad_(True)
    ad = torch.autograd.grad(loss(x, 0), x)[0].numpy().reshape(-1)
    fine = _rgb_geometry(renderer_cls, rgb_spp=256)
    fd = np.zeros(12)
    with torch.no_grad():
        for i in range(12):
            h = 0.02 * float(base.reshape(-1)[i])
            step = torch.zeros(12, dtype=torch.float64)
            step[i] = h
            fd[i] = float(loss(base + step.reshape(4, 3), 3, fine) - loss(base - step.reshape(4, 3), 3, fine)) / (2 * h)
    _check("RGB L2 (albedo, radiance)", ad, fd, labels)


def test_rgb_map_and_roughness_gradients_match_finite_differences(renderer_cls) -> None:
    """A UV-mapped base colour (the floor wears an 8×8 map, two repeats) and a constant roughness and
    specular: the derivative of an image loss along a random direction of all of them matches central
    differences."""
    from psdr_room_core.method.shading import planar_uv

    floor = _meshes()["floor"]
    split, uv_metres = planar_uv(floor)
    assert len(split.vertices) == len(floor.vertices)  # a flat quad stays one group
    rng = np.random.default_rng(3)
    texture = rng.uniform(0.2, 0.8, (8, 8, 3)).astype(np.float32)
    surface = Surface(base_color=texture, roughness=0.4, uv=uv_metres / np.ptp(uv_metres, axis=0).max() * 2.0)
    with torch.no_grad():
        target = _rgb_geometry(renderer_cls, {"floor": surface}, rgb_spp=256).render_rgb(
            base_color={"floor": torch.from_numpy(texture[::-1].copy())},
            roughness={"object": torch.tensor([0.1])},
            specular={"object": torch.tensor([1.0])},
            iteration=999,
        )
    renderer = _rgb_geometry(renderer_cls, {"floor": surface}, rgb_spp=64)
    fine = _rgb_geometry(renderer_cls, {"floor": surface}, rgb_spp=256)

    def loss(t: torch.Tensor, rough: torch.Tensor, spec: torch.Tensor, iteration: int, geometry) -> torch.Tensor:
        image = geometry.render_rgb(
            base_color={"floor": t}, roughness={"object": rough}, specular={"object": spec}, iteration=iteration
        )
        return ((image - target) ** 2).mean()

    t0, r0, s0 = torch.from_numpy(texture), torch.tensor([0.4]), torch.tensor([0.5])
    x = [t0.clone().requires_grad_(True), r0.clone().requires_grad_(True), s0.clone().requires_grad_(True)]
    grads = torch.autograd.grad(loss(*x, 0, renderer), x)
    assert grads[0].shape == (8, 8, 3) and float(grads[0].abs().sum()) > 0
    for k, name in enumerate(("map", "roughness", "specular")):
        direction = [torch.zeros_like(v) for v in x]
        direction[k] = torch.from_numpy(rng.normal(size=tuple(x[k].shape)).astype(np.float32))
        ad = float((grads[k] * direction[k]).sum())
        h = 0.05
        with torch.no_grad():
            plus = loss(*(v + h * d for v, d in zip((t0, r0, s0), direction)), 3, fine)
            minus = loss(*(v - h * d for v, d in zip((t0, r0, s0), direction)), 3, fine)
        fd = float(plus - minus) / (2 * h)
        assert np.sign(ad) == np.sign(fd) and 0.5 < ad / fd < 2.0, (name, ad, fd)


def test_frozen_rgb_passes_give_the_traced_images_and_gradients(renderer_cls) -> None:
    """``freeze`` replays recorded kernels; over iterations of new maps, colours, roughness and radiance (as a
    fit changes them) the images are the same and the gradients the same but for the order of atomic adds.
    Replays on inputs that mapped NumPy memory rendered NaN now and then: every iteration is checked."""
    from psdr_room_core.method.shading import planar_uv

    meshes = _meshes()
    mapped = ["floor", "ceiling", "wall_x_neg", "wall_x_pos"]
    rng = np.random.default_rng(4)
    surfaces = {}
    for name in mapped:
        uv = planar_uv(meshes[name])[1]
        surfaces[name] = Surface(
            base_color=rng.uniform(0.2, 0.8, (16, 16, 3)).astype(np.float32),
            roughness=rng.uniform(0.2, 0.8, (16, 16, 1)).astype(np.float32),
            uv=uv / np.ptp(uv, axis=0).max() * 2.0,
        )
    runs = []
    for freeze in (False, True):
        geometry = _rgb_geometry(lambda **k: renderer_cls(freeze=freeze, **k), surfaces, rgb_spp=8)
        values = np.random.default_rng(5)
        out = []
        for iteration in range(6):
            x = {
                f"{n}.{c}": torch.from_numpy(values.uniform(0.2, 0.8, (16, 16, k)).astype(np.float32)).requires_grad_()
                for n in mapped
                for c, k in (("colour", 3), ("roughness", 1))
            }
            x["object"] = torch.tensor(values.uniform(0.2, 0.8, 3), dtype=torch.float32, requires_grad=True)
            x["light"] = torch.tensor(values.uniform(5.0, 9.0, 3), dtype=torch.float32, requires_grad=True)
            image = geometry.render_rgb(
                base_color={**{n: x[f"{n}.colour"] for n in mapped}, "object": x["object"]},
                roughness={n: x[f"{n}.roughness"] for n in mapped},
                radiance={"light": x["light"]},
                iteration=iteration,
                spp=8,
                grad_spp=4,
            )
            grads = torch.autograd.grad((image**2).mean(), list(x.values()))
            out.append((image.detach().numpy(), [g.numpy() for g in grads]))
        runs.append(out)
    for (traced, traced_grads), (frozen, frozen_grads) in zip(*runs):
        assert np.all(np.isfinite(frozen)) and np.array_equal(traced, frozen)
        for a, b in zip(traced_grads, frozen_grads):
            assert np.abs(a).max() > 0 and np.allclose(a, b, rtol=1e-4, atol=1e-5 * np.abs(a).max())


def test_rgb_refuses_biased_geometry_gradients(renderer_cls) -> None:
    renderer = _rgb_geometry(renderer_cls, rgb_spp=4)
    theta = torch.zeros(10, dtype=torch.float64, requires_grad=True)
    with pytest.raises(PsdrRoomError, match="rgb_geometry_gradients"):
        renderer.render_rgb(_vertices(theta))
    with torch.no_grad():
        image = renderer.render_rgb(_vertices(theta))  # moved but not differentiated: fine
    assert image.shape == (H, W, 3) and float(image.mean()) > 0


def test_unknown_shape_and_bad_vertices_are_one_line_errors(renderer_cls) -> None:
    camera, c2w = _camera()
    renderer = renderer_cls(spp=2, spp_boundary=2).geometry(camera, c2w, _meshes(), PARTS)
    with pytest.raises(PsdrRoomError, match="unknown shape 'sofa'"):
        renderer.render({"sofa": torch.zeros(8, 3)})
    with pytest.raises(PsdrRoomError, match=r"shape \(8, 3\)"):
        renderer.render({"object": torch.zeros(4, 3)})
    with pytest.raises(PsdrRoomError, match="not in meshes"):
        renderer_cls().geometry(camera, c2w, _meshes(), {"sofa": 4})


def test_render_guides_show_the_given_surfaces(renderer_cls) -> None:
    import torch

    geometry = _rgb_geometry(renderer_cls, rgb_spp=4)
    albedo, normal = geometry.render_guides(base_color={"object": torch.tensor([0.1, 0.9, 0.2])}, spp=4)
    assert albedo.shape == normal.shape == (geometry.height, geometry.width, 3)
    covered = np.linalg.norm(normal, axis=-1) > 0.5
    assert covered.mean() > 0.9  # a closed room: every pixel sees a surface
    unit = np.abs(np.linalg.norm(normal[covered], axis=-1) - 1.0) < 1e-3
    assert unit.mean() > 0.9  # unit normals, but where a pixel's samples straddle a crease
    assert np.any(np.all(np.abs(albedo - [0.1, 0.9, 0.2]) < 1e-3, axis=-1))  # the new colour shows...
    assert not np.any(np.all(np.abs(albedo - [0.8, 0.3, 0.2]) < 1e-3, axis=-1))  # ...instead of the old one


def test_oidn_brings_a_noisy_render_towards_the_converged_one(renderer_cls) -> None:
    import torch

    from psdr_room_plugins.denoisers import OidnDenoiser

    geometry = _rgb_geometry(renderer_cls, rgb_spp=4)
    with torch.no_grad():
        noisy = geometry.render_rgb(spp=4, iteration=1).numpy()
        converged = geometry.render_rgb(spp=1024, iteration=2).numpy()
    clean = OidnDenoiser(quality="fast").denoise(noisy, *geometry.render_guides(spp=8))
    error = lambda x: float(np.sqrt(np.mean((np.clip(x, 0, 1) - np.clip(converged, 0, 1)) ** 2)))  # noqa: E731
    assert clean.shape == noisy.shape and clean.dtype == np.float32
    assert error(clean) < 0.5 * error(noisy)
