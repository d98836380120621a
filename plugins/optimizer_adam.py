"""``optimizer=adam``: Adam (torch) with per-parameter learning rates and an exponential decay."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting


class Adam:
    """Adam over named torch tensors; learning rates per tensor, multiplied by ``decay`` every iteration."""

    def __init__(self, beta1: float = 0.9, beta2: float = 0.999, eps: float = 1e-8, decay: float = 1.0) -> None:
        self.betas = (beta1, beta2)
        self.eps = eps
        self.decay = decay

    def minimize(
        self,
        params: dict[str, Any],
        learning_rates: dict[str, float],
        loss: Callable[[int], tuple[Any, dict[str, float]]],
        iterations: int,
        progress: Callable[[Iterable[int]], Iterable[int]] = iter,
        stop: Callable[[list[dict[str, float]]], bool] | None = None,
    ) -> list[dict[str, float]]:
        """Minimise ``loss(iteration) -> (scalar tensor, logged terms)`` in place, at most ``iterations`` steps,
        fewer where ``stop(log so far)`` is true; return the per-iteration log (the terms, plus ``seconds`` of
        wall time for the iteration: forward, backward and step)."""
        import torch

        groups = [
            {"params": [tensor], "lr": float(learning_rates[name]), "name": name} for name, tensor in params.items()
        ]
        optimizer = torch.optim.Adam(groups, betas=self.betas, eps=self.eps)
        schedule = torch.optim.lr_scheduler.ExponentialLR(optimizer, gamma=self.decay)
        history = []
        for iteration in progress(range(iterations)):
            start = time.perf_counter()
            optimizer.zero_grad(set_to_none=True)
            value, terms = loss(iteration)
            value.backward()
            optimizer.step()
            schedule.step()
            history.append({**terms, "loss": float(value.detach()), "seconds": time.perf_counter() - start})
            if stop is not None and stop(history):
                break
        return history


@dataclass
class AdamSettings:
    """``optimizer=adam``: Adam's constants (the learning rates are each stage's)."""

    beta1: float = setting(ge=0, lt=1, doc="Decay of the gradient's running mean.")
    beta2: float = setting(ge=0, lt=1, doc="Decay of the squared gradient's running mean.")
    eps: float = setting(gt=0, doc="Added to the denominator (numerical safety).")
    decay: float = setting(gt=0, le=1, doc="Learning rates are multiplied by this after every iteration (1: constant).")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("optimizer", "adam", Adam, params=AdamSettings, reads_files=False)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Optimizer

    _Adam_is_a_optimizer: type[Optimizer] = Adam
