"""When a fit is done, and which of its iterates to keep.

Renders are Monte-Carlo estimates, so a loss curve is noisy: a fit stops on a *plateau* of window means, not
on one iteration's value; and Adam with a constant rate can drift away from a minimum it has reached (a
parameter whose gradient is small but steady takes full-size steps), so a fit keeps its *best* iterate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.engine.settings import setting

if TYPE_CHECKING:
    import torch


def untimed(history: Sequence[dict[str, float]], timings: dict[str, float]) -> list[dict[str, float]]:
    """An optimizer's per-iteration log without its wall-clock ``seconds``, which go to ``timings`` instead
    (``first_iteration_seconds``, ``steady_iteration_seconds``: the median after the first), so that the
    artifacts a fit makes are the same on every run."""
    seconds = [h["seconds"] for h in history if "seconds" in h]
    if seconds:
        timings["first_iteration_seconds"] = seconds[0]
        timings["steady_iteration_seconds"] = float(np.median(seconds[1:] or seconds))
    return [{k: v for k, v in h.items() if k != "seconds"} for h in history]


@dataclass
class Plateau:
    """The loss has flattened: the mean of its last ``window`` values is less than ``tolerance`` × |that of the
    ``window`` before them| below it, after at least ``min_iterations`` (``window`` 0: never). The ``convergence``
    settings of the fitting stages."""

    window: int = setting(
        ge=0, doc="Iterations per window: the last window's mean loss is compared with the one before (0: never stop)."
    )
    tolerance: float = setting(
        ge=0,
        lt=1,
        doc="The loss has flattened where the last window's mean is less than this share below the one before "
        "(higher: stops sooner).",
    )
    min_iterations: int = setting(ge=0, doc="Iterations run before a plateau can stop the fit.")

    def __call__(self, history: Sequence[dict[str, float]]) -> bool:
        n = len(history)
        if self.window <= 0 or n < max(self.min_iterations, 2 * self.window):
            return False
        losses = [h["loss"] for h in history[-2 * self.window :]]
        before = sum(losses[: self.window]) / self.window
        after = sum(losses[self.window :]) / self.window
        return before - after < self.tolerance * abs(before)


class BestIterate:
    """A copy of the parameters at the lowest loss seen; :meth:`restore` puts it back in place."""

    def __init__(self, params: dict[str, torch.Tensor]) -> None:
        self.params = params
        self.loss = float("inf")
        self.iteration = -1
        self._saved: dict[str, torch.Tensor] = {}

    def observe(self, loss: float, iteration: int) -> None:
        """Record the parameters as they are now if ``loss`` (theirs) is the lowest yet."""
        if loss < self.loss:
            self.loss, self.iteration = loss, iteration
            self._saved = {name: tensor.detach().clone() for name, tensor in self.params.items()}

    def restore(self) -> None:
        """Set the parameters to the best iterate's values (nothing when none was observed)."""
        import torch

        with torch.no_grad():
            for name, value in self._saved.items():
                self.params[name].copy_(value)
