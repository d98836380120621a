"""When a fit stops (a plateau of window means) and which iterate it keeps (the best), alone and through Adam."""

from __future__ import annotations

import math

import torch

from psdr_room_core.method.convergence import BestIterate, Plateau
from psdr_room_plugins.optimizer_adam import Adam


def _log(losses: list[float]) -> list[dict[str, float]]:
    return [{"loss": v} for v in losses]


def test_a_falling_loss_goes_on_a_flat_or_rising_one_stops() -> None:
    plateau = Plateau(window=10, tolerance=0.01, min_iterations=30)
    falling = [1.0 * 0.97**i for i in range(60)]  # 3% per iteration: each window 26% below the last
    assert not any(plateau(_log(falling[:n])) for n in range(1, 61))
    flat = [0.5 + 0.01 * math.sin(7 * i) for i in range(40)]  # noise about a constant
    assert not plateau(_log(flat[:29])) and plateau(_log(flat[:30]))  # not before min_iterations
    rising = [0.2 + 0.005 * i for i in range(40)]
    assert plateau(_log(rising))
    negative = [-2.0 - 0.02 * i for i in range(40)]  # a falling negative loss (room_fit's -IoU) goes on
    assert not plateau(_log(negative)) and plateau(_log([-v for v in negative]))
    assert not Plateau(window=0, tolerance=0.01, min_iterations=30)(_log(flat))  # window 0: never


def test_the_best_iterate_is_restored() -> None:
    x = torch.tensor([1.0, 2.0], requires_grad=True)
    best = BestIterate({"x": x})
    best.observe(3.0, 0)
    with torch.no_grad():
        x += 1.0
    best.observe(5.0, 1)  # worse: not kept
    assert best.iteration == 0
    best.restore()
    assert x.tolist() == [1.0, 2.0]


def test_adam_stops_on_the_plateau() -> None:
    """A quadratic bowl over a floor (a render loss never reaches 0) is reached within ~100 of the 1000 steps
    allowed; the plateau ends the fit there."""
    x = torch.tensor([3.0], requires_grad=True)

    def bowl(iteration: int) -> tuple[torch.Tensor, dict[str, float]]:
        return (x**2).sum() + 1.0, {}

    history = Adam().minimize(
        {"x": x}, {"x": 0.1}, bowl, 1000, stop=Plateau(window=20, tolerance=0.01, min_iterations=40)
    )
    assert 40 <= len(history) < 300 and abs(float(x.detach())) < 0.2
    assert len(Adam().minimize({"x": x}, {"x": 0.1}, bowl, 50)) == 50  # no stop: all
