"""``psdr-room-train``: train the eyes network on a ``psdr-room-synth-data`` data set and export its ONNX.

Seeded and resumable: the run folder keeps ``checkpoint.pt`` (weights, optimiser, epoch, history with the seconds
spent, the schedule's length) after every ``--validate-every`` epochs, and a second call with the same folder goes
on from it, on the same learning-rate schedule and within what is left of ``--minutes``; then the held-out synthetic
samples (the highest seeds) are scored and ``curves.png`` is redrawn. At the end ``eyes.onnx`` (float16 weights) and
``eyes.json`` (its sha256, the data seeds, the command, the commit and the validation scores) are written.
Uses CUDA when there is a GPU (``--device auto``), else the CPU (``OMP_WAIT_POLICY=PASSIVE`` and one thread
per core are set: more threads than cores on a busy machine run several times slower). ``--precision bf16`` runs
the forward pass under bfloat16 autocast (weights, optimiser and losses stay float32): on a CPU with AVX-512 BF16
a step of 32 takes 1.2 s instead of 3.1 s.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

if TYPE_CHECKING:
    import torch

    from psdr_room_plugins.eyes.data import Pack

LOSS_WEIGHTS = {
    "surface": 1.0,
    "category": 1.0,
    "center": 1.0,
    "offset": 0.1,
    "depth": 1.0,
    "box_depth": 1.0,
    "box_size": 1.0,
    "yaw_bin": 0.5,
    "yaw_residual": 0.5,
    "amodal": 0.5,
    "embedding": 0.5,
}
EMBEDDING_SCALE = 16.0
"""Cosine similarities to the model proxies are multiplied by this before the softmax (normalised softmax loss)."""
TIMING_STEPS = 20
"""``--minutes`` times steps TIMING_STEPS..2·TIMING_STEPS of a run (after its warm-up) to set the number of steps."""
PRECISION = ("fp32", "bf16")
"""The forward pass's arithmetic: float32, or bfloat16 autocast (mixed precision; no loss scaling needed)."""
FREEZE = ("none", "stride8", "encoder", "plane")
"""What stays fixed: nothing, the encoder's layers up to stride 8, all of the encoder
(:meth:`psdr_room_plugins.eyes.encoder.OnnxEncoder.frozen`), or the encoder and the image-plane heads (``plane``:
only the 3D heads train, from ``--init``'s weights)."""


def losses(out: dict, batch: dict, proxies: torch.Tensor | None = None) -> dict:
    """Each head's loss on a batch (torch tensors; targets from :func:`psdr_room_plugins.eyes.data.example`);
    the embedding's given the model ``proxies``."""
    import torch
    import torch.nn.functional as F

    from psdr_room_plugins.eyes.data import IGNORE

    terms = {"surface": F.cross_entropy(out["surface"], batch["surface"])}
    labelled = (batch["category"] != IGNORE).sum()
    terms["category"] = F.cross_entropy(
        out["category"], batch["category"], ignore_index=IGNORE, reduction="sum"
    ) / labelled.clamp(min=1)
    p, gt = out["center"].clamp(1e-4, 1 - 1e-4), batch["center"]  # CenterNet's penalty-reduced focal loss
    positive = gt.eq(1.0).float()
    focal = -(positive * (1 - p) ** 2 * torch.log(p) + (1 - positive) * (1 - gt) ** 4 * p**2 * torch.log(1 - p))
    terms["center"] = focal.sum() / positive.sum().clamp(min=1)
    weight = batch["offset_weight"]
    terms["offset"] = ((out["offset"] - batch["offset"]).abs() * weight).sum() / (2 * weight.sum()).clamp(min=1)
    valid = batch["depth"] > 0
    difference = torch.where(valid, out["depth"] - torch.log(batch["depth"].clamp(min=1e-3)), 0.0)
    count = valid.flatten(1).sum(1).clamp(min=1)
    mean = difference.flatten(1).sum(1) / count
    squared = (difference**2).flatten(1).sum(1) / count
    terms["depth"] = (squared - 0.85 * mean**2).clamp(min=0).sqrt().mean()  # scale-invariant log error
    return terms | box_losses(out, batch, proxies)


def box_losses(out: dict, batch: dict, proxies: torch.Tensor | None = None) -> dict:
    """The 3D heads' losses (targets from :func:`psdr_room_plugins.eyes.data.box_targets`): L1 on the pixels of
    instances with a box for depth, size, amodal extent and the true bin's yaw residual, cross-entropy for the
    yaw bin and, given the model ``proxies`` [models, EMBEDDING], a normalised softmax of each instance's mean
    embedding against them."""
    import torch.nn.functional as F

    from psdr_room_plugins.eyes.data import IGNORE

    weight = batch["box_weight"]
    pixels = weight.sum().clamp(min=1)
    terms = {
        name: ((out[name] - batch[name]).abs() * weight).sum() / (pixels * out[name].shape[1])
        for name in ("box_depth", "box_size", "amodal")
    }
    terms["yaw_bin"] = F.cross_entropy(out["yaw_bin"], batch["yaw_bin"], ignore_index=IGNORE, reduction="sum") / pixels
    true_bin = batch["yaw_bin"].clamp(min=0)[:, None]
    residual = out["yaw_residual"].gather(1, true_bin)[:, 0]
    terms["yaw_residual"] = ((residual - batch["yaw_residual"]).abs() * weight[:, 0]).sum() / pixels
    if proxies is not None:
        terms["embedding"] = embedding_loss(out["embedding"], batch["slot"], batch["slot_model"], proxies)
    return terms


def pooled_embeddings(embedding: torch.Tensor, slot: torch.Tensor, slot_model: torch.Tensor):
    """(unit mean embedding [K, E], model index [K]) of each instance of a batch with a model: ``embedding`` [B,
    E, h, w] averaged over the pixels of each ``slot`` [B, h, w] (-1 none), ``slot_model`` [B, S] its model."""
    import torch
    import torch.nn.functional as F

    batch, channels = embedding.shape[:2]
    slots = slot_model.shape[1]
    index = torch.where(slot >= 0, slot + slots * torch.arange(batch, device=slot.device)[:, None, None], -1)
    index = index.flatten()
    keep = index >= 0
    values = embedding.permute(0, 2, 3, 1).reshape(-1, channels)[keep]
    sums = torch.zeros(batch * slots, channels, device=embedding.device).index_add(0, index[keep], values)
    counts = torch.zeros(batch * slots, device=embedding.device).index_add(
        0, index[keep], torch.ones_like(index[keep], dtype=embedding.dtype)
    )
    models = slot_model.flatten()
    present = (counts > 0) & (models >= 0)
    return F.normalize(sums[present] / counts[present, None], dim=1), models[present]


def embedding_loss(embedding: torch.Tensor, slot: torch.Tensor, slot_model: torch.Tensor, proxies: torch.Tensor):
    """Normalised softmax cross-entropy of the batch's instance embeddings against the model proxies."""
    import torch.nn.functional as F

    pooled, models = pooled_embeddings(embedding, slot, slot_model)
    if len(models) == 0:
        return embedding.sum() * 0.0
    logits = EMBEDDING_SCALE * pooled @ F.normalize(proxies, dim=1).T
    return F.cross_entropy(logits, models)


def predict(net: torch.nn.Module, images: torch.Tensor, precision: str = "fp32") -> dict[str, torch.Tensor]:
    """The network's float32 outputs on ``images`` [B, 3, H, W] in [0, 1], its forward pass run in
    ``precision`` (:data:`PRECISION`) on the images' device."""
    import torch

    with torch.autocast(images.device.type, dtype=torch.bfloat16, enabled=precision == "bf16"):
        out = net(images)
    return {k: v.float() for k, v in out.items()}


def validate(
    net, pack, indices: Sequence[int] | np.ndarray, device: str, batch_size: int, proxies: np.ndarray | None = None
) -> dict[str, float]:
    """Held-out scores: surface pixel accuracy, object-pixel category accuracy, depth AbsRel and δ<1.25 after
    a median scale, instance recall (decoded instances with mask IoU ≥ 0.5 per reference instance), and over
    the recalled instances with a box (:func:`box_errors`) the 3D heads' median errors."""
    import torch

    from psdr_room_plugins.eyes.data import example
    from psdr_room_plugins.eyes.decode import instances, median_scaled
    from psdr_room_plugins.eyes.labels import OBJECT

    net.eval()
    counts = {"surface": [0, 0], "category": [0, 0], "recall": [0, 0]}
    absrel, delta = [], []
    errors: list[dict[str, float]] = []
    with torch.no_grad():
        for start in range(0, len(indices), batch_size):
            items = [example(pack, int(i), None) for i in indices[start : start + batch_size]]
            images = torch.from_numpy(np.stack([it["image"] for it in items])).to(device).float() / 255.0
            out = {k: v.cpu().numpy() for k, v in predict(net, images).items()}
            for b, item in enumerate(items):
                surface = out["surface"][b].argmax(0)
                counts["surface"][0] += int((surface == item["surface"]).sum())
                counts["surface"][1] += surface.size
                labelled = item["category"] >= 0
                counts["category"][0] += int(
                    (out["category"][b].argmax(0)[labelled] == item["category"][labelled]).sum()
                )
                counts["category"][1] += int(labelled.sum())
                reference = item["depth"][0]
                if (reference > 0).any():
                    depth = median_scaled(out["depth"][b][0], reference)[reference > 0]
                    truth = reference[reference > 0]
                    absrel.append(float(np.mean(np.abs(depth - truth) / truth)))
                    delta.append(float(np.mean(np.maximum(depth / truth, truth / depth) < 1.25)))
                found = instances(out["surface"][b], out["category"][b], out["center"][b], out["offset"][b])
                sample = int(indices[start + b])
                instance_map = pack.instance[sample]
                rows = {int(pack.box_instance[r]): r for r in pack.boxes(sample)}
                for value in np.unique(instance_map[instance_map != 0]):
                    mask = (instance_map == value) & (item["surface"] == OBJECT)
                    if mask.sum() < 6:
                        continue
                    counts["recall"][1] += 1
                    match = next((m for m in found if (m.mask & mask).sum() / (m.mask | mask).sum() >= 0.5), None)
                    counts["recall"][0] += match is not None
                    if match is not None and int(value) in rows:
                        outputs = {k: v[b] for k, v in out.items()}
                        errors.append(box_errors(pack, rows[int(value)], outputs, match.mask, proxies))
    net.train()
    return {
        "surface_accuracy": counts["surface"][0] / max(counts["surface"][1], 1),
        "category_accuracy": counts["category"][0] / max(counts["category"][1], 1),
        "instance_recall": counts["recall"][0] / max(counts["recall"][1], 1),
        "depth_absrel": float(np.mean(absrel)) if absrel else float("nan"),
        "depth_delta1": float(np.mean(delta)) if delta else float("nan"),
        **{key: float(np.median([e[key] for e in errors])) if errors else float("nan") for key in BOX_SCORES},
        **({"model_top1": float(np.mean([e["model_top1"] for e in errors]))} if errors and proxies is not None else {}),
    }


BOX_SCORES = ("box_depth_absrel", "box_yaw_deg", "box_size_logerr", "box_amodal_iou")
"""The 3D heads' validation scores: medians over recalled instances with a box."""


def box_errors(pack, row: int, out: dict[str, np.ndarray], mask: np.ndarray, proxies: np.ndarray | None) -> dict:
    """How far the box read on ``mask`` (:func:`psdr_room_plugins.eyes.box3d.read_box`) is from box ``row`` of
    the pack: the centre's depth AbsRel, the yaw error in degrees, the mean |log| size ratio, the amodal boxes'
    IoU and, given the model ``proxies``, whether the nearest is the model's."""
    from psdr_room_core.method.image_boxes import box_iou
    from psdr_room_plugins.eyes.box3d import read_box, wrap, yaw_of

    sample = int(pack.box_sample[row])
    fx, fy = (float(v) for v in pack.focal[sample])
    box = read_box(out, mask, fx, fy)
    truth = pack.box_center[row]
    errors = {
        "box_depth_absrel": abs(box.center[2] - truth[2]) / truth[2],
        "box_yaw_deg": abs(float(np.degrees(wrap(box.yaw - yaw_of(pack.box_alpha[row], truth))))),
        "box_size_logerr": float(np.mean(np.abs(np.log(box.size / pack.box_size[row])))),
        "box_amodal_iou": float(box_iou(box.amodal, pack.box_amodal[row][None])[0]),
    }
    if proxies is not None:
        unit = proxies / np.linalg.norm(proxies, axis=1, keepdims=True)
        errors["model_top1"] = float(int(np.argmax(unit @ box.embedding)) == int(pack.box_model[row]))
    return errors


_PACK: Pack | None = None


def _keep_pack(pack: Pack) -> None:  # a worker process's pack (inherited by fork, not pickled)
    global _PACK
    _PACK = pack


def _make_batch(group: tuple[np.ndarray, np.ndarray]) -> dict[str, np.ndarray]:
    from psdr_room_plugins.eyes.data import example

    assert _PACK is not None, "the pool's initializer keeps the pack"
    items = [example(_PACK, int(i), np.random.default_rng(int(s))) for i, s in zip(*group)]
    return {key: np.stack([it[key] for it in items]) for key in items[0]}


def _batches(indices: np.ndarray, batch_size: int, seed: int, epoch: int, pool=None):
    """Augmented training batches of one epoch (numpy) of the kept pack, shuffled by (seed, epoch); made by
    ``pool``'s processes when given (each sample's augmentation is seeded, so the batches are the same)."""
    rng = np.random.default_rng([seed, epoch])
    order = rng.permutation(indices)
    seeds = rng.integers(0, 2**31, len(order))
    groups = [
        (order[k : k + batch_size], seeds[k : k + batch_size])
        for k in range(0, len(order) - batch_size + 1, batch_size)
    ]
    yield from (pool.map(_make_batch, groups) if pool is not None else map(_make_batch, groups))


def _workers(pack, count: int):
    """A pool of ``count`` processes that inherit ``pack`` (fork: not copied per batch), or None for one."""
    _keep_pack(pack)
    if count <= 1:
        return None
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(count, mp_context=multiprocessing.get_context("fork"))


def _commit() -> str:
    """The code's git commit: ``PSDR_ROOM_COMMIT`` when set (a copy of the checkout on another machine may carry
    a stale or no ``.git``), else ``git rev-parse HEAD``."""
    if os.environ.get("PSDR_ROOM_COMMIT"):
        return os.environ["PSDR_ROOM_COMMIT"]
    try:
        return subprocess.run(
            ["git", "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            cwd=Path(__file__).resolve().parent,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def plot(history: list[dict], path: Path) -> None:
    """Training loss per epoch and validation scores, as a PNG."""
    import cv2

    from psdr_room_core.method.visualize import plot_curves

    curves = {"training loss": [h["loss"] for h in history]}
    for key in ("surface_accuracy", "category_accuracy", "instance_recall", "depth_absrel"):
        curves[f"validation {key}"] = [h[key] for h in history]
    cv2.imwrite(str(path), plot_curves(curves, size=(640, 300), title="eyes training (per epoch)")[..., ::-1])


def train(args: argparse.Namespace) -> dict:
    """Train (or resume) per ``args``; the final validation scores."""
    import torch

    from psdr_room_plugins.eyes.box3d import CATALOGUE, EMBEDDING
    from psdr_room_plugins.eyes.data import Pack, build_pack
    from psdr_room_plugins.eyes.network import EyesNet, export_onnx

    torch.manual_seed(args.seed)
    device = ("cuda" if torch.cuda.is_available() else "cpu") if args.device == "auto" else args.device
    if device == "cpu":
        torch.set_num_threads(args.threads or os.cpu_count() or 1)
    else:
        torch.backends.cudnn.benchmark = True  # one input size: let cuDNN pick its fastest convolutions
    args.out.mkdir(parents=True, exist_ok=True)
    pack_path = args.pack or args.out / "pack.npz"
    if args.pack is None and not pack_path.is_file():
        print(f"psdr-room-train: packing {args.data} into {pack_path}", flush=True)
        build_pack(args.data, pack_path, limit=args.limit)
    pack = Pack.load(pack_path)
    training, held = pack.split(args.validation)
    net = EyesNet()
    if args.init is not None:
        lacking = net.load_onnx(args.init)
        print(f"psdr-room-train: weights from {args.init} ({len(lacking)} new parameter tensors)", flush=True)
    net = net.to(device)
    if args.freeze == "plane":
        net.freeze_plane()
    else:
        for key in net.encoder.frozen(args.freeze):
            net.encoder.params[key].requires_grad_(False)
    proxies = torch.nn.Parameter(0.1 * torch.randn(len(pack.models), EMBEDDING, device=device))
    groups = [
        {"params": [p for p in net.encoder_parameters() if p.requires_grad], "lr": args.lr_encoder},
        {"params": [p for p in net.head_parameters() if p.requires_grad] + [proxies], "lr": args.lr_head},
    ]
    optimiser = torch.optim.AdamW([g for g in groups if g["params"]], weight_decay=1e-4)
    steps_per_epoch = max(1, len(training) // args.batch)
    total = args.steps or args.epochs * steps_per_epoch
    base = [g["lr"] for g in optimiser.param_groups]
    checkpoint = args.out / "checkpoint.pt"
    history: list[dict] = []
    epoch = step = 0
    spent = 0.0  # seconds of training before this call: the --minutes budget is the whole run's
    if checkpoint.is_file():
        state = torch.load(checkpoint, map_location=device, weights_only=False)
        net.load_state_dict(state["net"])
        proxies.data.copy_(state["proxies"])
        optimiser.load_state_dict(state["optimiser"])
        epoch, step, history = state["epoch"], state["step"], state["history"]
        spent = history[-1]["seconds"]  # a checkpoint is saved after its history's entry
        total = args.steps or state["total"]  # the schedule set by the first call, unless --steps says otherwise
        print(
            f"psdr-room-train: resuming {checkpoint} at epoch {epoch}, step {step} of {total}, "
            f"after {spent / 60:.1f} min",
            flush=True,
        )
    print(
        f"psdr-room-train: {len(training)} training and {len(held)} held-out samples, batch {args.batch}, "
        f"{total} steps on {device}, encoder frozen: {args.freeze}",
        flush=True,
    )
    net.train()
    pool = _workers(pack, args.workers)
    first = step
    began = timed = time.monotonic()
    while step < total:
        sums: dict[str, float] = {}
        count = 0
        for batch in _batches(training, args.batch, args.seed, epoch, pool):
            if step >= total:
                break
            warm = min(1.0, (step + 1) / args.warmup)
            for group, lr in zip(optimiser.param_groups, base):
                group["lr"] = lr * warm * 0.5 * (1 + math.cos(math.pi * step / total))
            tensors = {k: torch.from_numpy(v).to(device, non_blocking=True) for k, v in batch.items()}
            terms = losses(predict(net, tensors["image"].float() / 255.0, args.precision), tensors, proxies)
            loss = sum(LOSS_WEIGHTS[k] * v for k, v in terms.items())
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 5.0)
            optimiser.step()
            step += 1
            count += 1
            if step == first + TIMING_STEPS:  # past the warm-up (first batches, cuDNN's choices): start the clock
                timed = time.monotonic()
            if args.minutes and step == first + 2 * TIMING_STEPS:  # fit the schedule into the time given
                per_step = (time.monotonic() - timed) / TIMING_STEPS
                left = args.minutes * 60 * 0.9 - spent - (time.monotonic() - began)
                total = min(total, step + max(0, int(left / per_step)))
                print(f"psdr-room-train: {per_step:.3f} s per step: {total} steps in {args.minutes} min", flush=True)
            for k, v in {"loss": loss, **terms}.items():
                sums[k] = sums.get(k, 0.0) + float(v.detach())
        epoch += 1
        if epoch % args.validate_every and step < total:
            continue
        scores = validate(net, pack, held, device, args.batch, proxies.detach().cpu().numpy())
        history.append(
            {
                "epoch": epoch,
                "step": step,
                "seconds": spent + time.monotonic() - began,
                **{k: v / max(count, 1) for k, v in sums.items()},
                **scores,
            }
        )
        print(
            "psdr-room-train: "
            + " ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in history[-1].items()),
            flush=True,
        )
        partial = checkpoint.with_suffix(".part")
        torch.save(
            {
                "net": net.state_dict(),
                "proxies": proxies.detach(),
                "optimiser": optimiser.state_dict(),
                "epoch": epoch,
                "step": step,
                "history": history,
                "total": total,
            },
            partial,
        )
        partial.replace(checkpoint)
        plot(history, args.out / "curves.png")
    if pool is not None:
        pool.shutdown(cancel_futures=True)
    onnx_path = export_onnx(net.cpu(), args.out / "eyes.onnx", half=True)
    catalogue = write_catalogue(args.out / CATALOGUE, pack.models, proxies.detach().cpu().numpy())
    note = {
        "sha256": hashlib.sha256(onnx_path.read_bytes()).hexdigest(),
        "catalogue": {"file": catalogue.name, "sha256": hashlib.sha256(catalogue.read_bytes()).hexdigest()},
        "command": " ".join(["psdr-room-train", *sys.argv[1:]]),
        "commit": _commit(),
        "data_seeds": [int(pack.seeds.min()), int(pack.seeds.max())],
        "samples": len(pack),
        "held_out": len(held),
        "epochs": epoch,
        "steps": step,
        "device": device,
        "freeze": args.freeze,
        "init": init_record(args.init) if args.init else None,
        "precision": args.precision,
        "validation": history[-1] if history else {},
    }
    (args.out / "eyes.json").write_text(json.dumps(note, indent=2) + "\n")
    print(f"psdr-room-train: wrote {onnx_path} ({onnx_path.stat().st_size / 1e6:.1f} MB)", flush=True)
    return note["validation"]


def init_record(path: Path) -> dict:
    """What a run started from: the network file and the note beside it (how those weights were made)."""
    note = path.with_suffix(".json")
    return {"file": str(path), "note": json.loads(note.read_text()) if note.is_file() else None}


def write_catalogue(path: Path, models: np.ndarray, proxies: np.ndarray) -> Path:
    """The catalogue file: each model id the network learnt (``model_ids``) with its unit embedding
    (``embeddings``, float32); the path."""
    unit = proxies / np.linalg.norm(proxies, axis=1, keepdims=True)
    partial = path.with_suffix(".part.npz")
    np.savez(partial, model_ids=np.asarray(models, str), embeddings=unit.astype(np.float32))
    partial.replace(path)
    return path


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of ``psdr-room-train``."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    parser = argparse.ArgumentParser(description="Train the eyes network on a psdr-room-synth-data data set.")
    parser.add_argument("--data", type=Path, help="data set folder (packed into OUT/pack.npz on first use)")
    parser.add_argument("--pack", type=Path, help="a pack made before (instead of --data)")
    parser.add_argument("--out", type=Path, required=True, help="run folder: checkpoint, curves, eyes.onnx")
    parser.add_argument("--epochs", type=int, default=12, help="the schedule's length (a resumed run keeps its own)")
    parser.add_argument("--steps", type=int, default=0, help="stop after this many steps (0: the epochs')")
    parser.add_argument(
        "--minutes",
        type=float,
        default=0.0,
        help="fewer steps when the epochs' would take longer than this, resumed calls included (timed after the "
        "warm-up)",
    )
    parser.add_argument("--batch", type=int, default=8)
    parser.add_argument("--lr-head", type=float, default=1e-3)
    parser.add_argument("--lr-encoder", type=float, default=1e-4)
    parser.add_argument("--warmup", type=int, default=200, help="steps of linear learning-rate warm-up")
    parser.add_argument(
        "--freeze",
        choices=FREEZE,
        default="stride8",
        help="what stays fixed: nothing, the encoder up to stride 8, the encoder, or the encoder and the "
        "image-plane heads (plane: only the 3D heads train; give --init)",
    )
    parser.add_argument(
        "--init", type=Path, help="an eyes.onnx whose weights start the run (the shipped one: plugins/eyes/eyes.onnx)"
    )
    parser.add_argument(
        "--precision",
        choices=PRECISION,
        default="fp32",
        help="the forward pass's arithmetic: fp32, or bf16 autocast (2.6x faster on a CPU with AVX-512 BF16)",
    )
    parser.add_argument("--validation", type=float, default=0.05, help="fraction of samples held out")
    parser.add_argument(
        "--validate-every",
        type=int,
        default=1,
        help="score the held-out samples (and save a checkpoint) every this many epochs, and after the last",
    )
    parser.add_argument("--limit", type=int, help="pack at most this many samples")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda")
    parser.add_argument("--threads", type=int, default=0, help="torch threads on the CPU (0: one per core)")
    parser.add_argument("--workers", type=int, default=1, help="processes making augmented batches")
    args = parser.parse_args(argv)
    if args.data is None and args.pack is None:
        parser.error("give --data (a psdr-room-synth-data folder) or --pack")
    if args.init is not None and not args.init.is_file():
        parser.error(f"--init {args.init}: no such file (an eyes.onnx psdr-room-train wrote)")
    if args.freeze == "plane" and args.init is None:
        parser.error("--freeze plane keeps the image-plane heads as --init gives them: give --init")
    if args.pack is not None and not args.pack.is_file():
        parser.error(f"--pack {args.pack}: no such file (make one with --data)")
    if args.pack is None and not (args.out / "pack.npz").is_file() and not any(args.data.glob("*.npz")):
        parser.error(f"--data {args.data}: no samples there (make them with psdr-room-synth-data --out {args.data})")
    if min(args.batch, args.epochs) < 1 or not 0 < args.validation < 1:
        parser.error("--batch and --epochs must be at least 1 and --validation between 0 and 1")
    try:
        train(args)
    except PsdrRoomError as exc:
        parser.exit(PsdrRoomError.exit_code, f"psdr-room-train: error: {exc}\n")
