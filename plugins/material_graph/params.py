"""Typed, bounded node parameters and the sigmoid reparameterisation that keeps them valid (§3.2).

A node type declares its parameters with a :class:`ParamSpec` each: continuous ones (:class:`Float`,
:class:`Color`, :class:`Floats`, :class:`Ramp`) carry hard bounds ``[lo, hi]``; discrete ones (:class:`Int`,
:class:`Choice`) are plain Python values that stay fixed during optimisation, as in the paper (counts,
seeds, modes). A graph file may narrow a continuous parameter's range (the plausible manifold of that
material) and may fix it.

Optimisation works on an unconstrained tensor ``u`` per continuous parameter; the value the node sees is
``lo + (hi - lo) * sigmoid(u)``, so any step of the optimiser gives a valid value and the gradient never
vanishes at a hard clamp. :func:`to_unconstrained` is the inverse used for initial values (clamped a hair
inside the range so that ``u`` is finite).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import torch

EPS = 0.01
"""Initial values are clamped to ``[lo + EPS·(hi-lo), hi - EPS·(hi-lo)]``: ``u`` is finite and the sigmoid's
slope there (≈ EPS) still lets a parameter that starts at a bound move."""

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")


class ParamError(ValueError):
    """A parameter value that does not fit its spec; the graph loader adds the file, node and field."""


def parse_color(value: Any) -> list[float]:
    """``"#rrggbb"`` (sRGB bytes) or ``[r, g, b]`` in [0, 1] → three floats."""
    if isinstance(value, str):
        match = _HEX.match(value.strip())
        if not match:
            raise ParamError(f"colour {value!r} is not '#rrggbb' or [r, g, b]")
        digits = match.group(1)
        return [int(digits[i : i + 2], 16) / 255.0 for i in (0, 2, 4)]
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return [float(value)] * 3
    if isinstance(value, Sequence) and len(value) == 3 and all(_is_number(v) for v in value):
        return [float(v) for v in value]
    raise ParamError(f"colour {value!r} is not '#rrggbb' or [r, g, b]")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


# ------------------------------------------------------------------------------------------- specs
@dataclass(frozen=True)
class ParamSpec:
    """Base of every parameter spec; ``doc`` is shown by ``psdr-room-materials nodes``."""

    doc: str = field(default="", kw_only=True)

    continuous = False

    def parse(self, raw: Any) -> Any:  # pragma: no cover - overridden
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - overridden
        raise NotImplementedError


@dataclass(frozen=True)
class Int(ParamSpec):
    """A discrete integer in ``[lo, hi]`` (a multiple of ``step`` when step > 1); fixed in optimisation."""

    lo: int = 0
    hi: int = 1
    default: int = 0
    step: int = 1

    def parse(self, raw: Any) -> int:
        if isinstance(raw, bool) or not isinstance(raw, (int, float)) or int(raw) != raw:
            raise ParamError(f"must be an integer in [{self.lo}, {self.hi}], got {raw!r}")
        value = int(raw)
        if not self.lo <= value <= self.hi:
            raise ParamError(f"must be an integer in [{self.lo}, {self.hi}], got {value}")
        if self.step > 1 and value % self.step:
            raise ParamError(f"must be a multiple of {self.step} (so that the pattern tiles), got {value}")
        return value

    def describe(self) -> str:
        step = f", multiple of {self.step}" if self.step > 1 else ""
        return f"int [{self.lo}, {self.hi}]{step}, default {self.default}"


def Seed(doc: str = "random seed") -> Int:  # noqa: N802 - reads like a spec class
    """The seed of a random pattern (discrete, fixed in optimisation)."""
    return Int(0, 2**31 - 1, 0, doc=doc)


@dataclass(frozen=True)
class Choice(ParamSpec):
    """One of a fixed set of names (a mode); fixed in optimisation."""

    options: tuple[str, ...] = ()
    default: str = ""

    def parse(self, raw: Any) -> str:
        if raw not in self.options:
            raise ParamError(f"must be one of {', '.join(self.options)}, got {raw!r}")
        return str(raw)

    def describe(self) -> str:
        return f"one of {' | '.join(self.options)}, default {self.default}"


@dataclass(frozen=True)
class Continuous(ParamSpec):
    """A real-valued tensor parameter with element-wise hard bounds; optimised through ``u``."""

    lo: float = 0.0
    hi: float = 1.0

    continuous = True

    def parse_value(self, raw: Any) -> torch.Tensor:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def default_value(self) -> Any:  # pragma: no cover - overridden
        raise NotImplementedError

    def parse(self, raw: Any) -> Bound:
        """A graph file's value: ``V`` or ``{value: V, range: [lo, hi], spread: s, fixed: bool}``."""
        options: dict[str, Any] = {}
        if isinstance(raw, dict):
            unknown = sorted(set(raw) - {"value", "range", "spread", "fixed"})
            if unknown:
                raise ParamError(f"unknown key(s) {', '.join(unknown)}; use value, range, spread, fixed")
            if "value" not in raw:
                raise ParamError("a parameter given as a mapping needs 'value'")
            options = raw
            raw = raw["value"]
        value = self.parse_value(raw)
        lo = torch.full_like(value, self.lo)
        hi = torch.full_like(value, self.hi)
        if not bool(((value >= lo - 1e-6) & (value <= hi + 1e-6)).all()):
            raise ParamError(f"value {_show(value)} is outside [{self.lo}, {self.hi}]")
        if "range" in options and "spread" in options:
            raise ParamError("give either range or spread, not both")
        if "range" in options:
            rng = options["range"]
            if not (isinstance(rng, Sequence) and not isinstance(rng, str) and len(rng) == 2):
                raise ParamError(f"range must be [lo, hi], got {rng!r}")
            try:
                r_lo = torch.broadcast_to(self._range_end(rng[0]), value.shape).clone()
                r_hi = torch.broadcast_to(self._range_end(rng[1]), value.shape).clone()
            except (RuntimeError, ParamError, TypeError, ValueError):
                raise ParamError(f"range {rng!r} does not fit a value of shape {list(value.shape)}") from None
            if bool((r_lo < lo - 1e-6).any()) or bool((r_hi > hi + 1e-6).any()):
                raise ParamError(f"range {rng!r} reaches outside the node's bounds [{self.lo}, {self.hi}]")
            if bool((r_lo > r_hi).any()):
                raise ParamError(f"range {rng!r} has lo > hi")
            lo, hi = r_lo, r_hi
        if "spread" in options:
            spread = options["spread"]
            if not _is_number(spread) or spread < 0:
                raise ParamError(f"spread must be a number >= 0, got {spread!r}")
            lo = torch.maximum(lo, value - float(spread))
            hi = torch.minimum(hi, value + float(spread))
        if bool(((value < lo - 1e-6) | (value > hi + 1e-6)).any()):
            raise ParamError(f"value {_show(value)} is outside its range [{_show(lo)}, {_show(hi)}]")
        fixed = options.get("fixed", False)
        if not isinstance(fixed, bool):
            raise ParamError(f"fixed must be true or false, got {fixed!r}")
        return Bound(value=value.clamp(lo, hi), lo=lo, hi=hi, fixed=fixed or bool((hi - lo <= 1e-9).all()))

    def _range_end(self, raw: Any) -> torch.Tensor:
        if _is_number(raw):
            return torch.tensor(float(raw))
        return self.parse_value(raw)

    def default_bound(self) -> Bound:
        return self.parse(self.default_value)


def _show(t: torch.Tensor) -> str:
    values = [round(float(v), 4) for v in t.flatten()]
    return str(values[0]) if len(values) == 1 else str(values)


@dataclass(frozen=True)
class Float(Continuous):
    """A real number in ``[lo, hi]``."""

    default: float = 0.0

    def parse_value(self, raw: Any) -> torch.Tensor:
        if not _is_number(raw):
            raise ParamError(f"must be a number in [{self.lo}, {self.hi}], got {raw!r}")
        return torch.tensor(float(raw))

    @property
    def default_value(self) -> float:
        return self.default

    def describe(self) -> str:
        return f"float [{self.lo}, {self.hi}], default {self.default}"


@dataclass(frozen=True)
class Color(Continuous):
    """An RGB colour, each channel in [0, 1] (``"#rrggbb"`` or ``[r, g, b]`` in files)."""

    default: str = "#808080"

    def parse_value(self, raw: Any) -> torch.Tensor:
        return torch.tensor(parse_color(raw))

    @property
    def default_value(self) -> str:
        return self.default

    def describe(self) -> str:
        return f"colour, default {self.default}"


@dataclass(frozen=True)
class Floats(Continuous):
    """A list of reals, each in ``[lo, hi]`` (e.g. curve control values); its length is fixed by the file."""

    default: tuple[float, ...] = ()
    min_len: int = 2

    def parse_value(self, raw: Any) -> torch.Tensor:
        if (
            not isinstance(raw, Sequence)
            or isinstance(raw, str)
            or len(raw) < self.min_len
            or not all(_is_number(v) for v in raw)
        ):
            raise ParamError(
                f"must be a list of at least {self.min_len} numbers in [{self.lo}, {self.hi}], got {raw!r}"
            )
        return torch.tensor([float(v) for v in raw])

    def _range_end(self, raw: Any) -> torch.Tensor:
        return torch.tensor(float(raw)) if _is_number(raw) else self.parse_value(raw)

    @property
    def default_value(self) -> list[float]:
        return list(self.default)

    def describe(self) -> str:
        return f"list of floats in [{self.lo}, {self.hi}], default {list(self.default)}"


@dataclass(frozen=True)
class Ramp(Continuous):
    """A colour ramp: ``[[position, colour], ...]`` with positions in [0, 1] (sorted when evaluated).

    Stored as an N×4 tensor (position, r, g, b); every entry is continuous in [0, 1].
    """

    default: tuple[tuple[float, str], ...] = ((0.0, "#000000"), (1.0, "#ffffff"))

    def parse_value(self, raw: Any) -> torch.Tensor:
        if not isinstance(raw, Sequence) or isinstance(raw, str) or len(raw) < 2:
            raise ParamError(f"must be a list of at least two [position, colour] stops, got {raw!r}")
        rows = []
        for stop in raw:
            if not isinstance(stop, Sequence) or isinstance(stop, str) or len(stop) != 2 or not _is_number(stop[0]):
                raise ParamError(f"each stop must be [position, colour], got {stop!r}")
            rows.append([float(stop[0]), *parse_color(stop[1])])
        return torch.tensor(rows)

    def _range_end(self, raw: Any) -> torch.Tensor:
        if _is_number(raw):
            return torch.tensor(float(raw))
        raise ParamError("a ramp's range is two numbers")

    @property
    def default_value(self) -> list[list[Any]]:
        return [list(s) for s in self.default]

    def describe(self) -> str:
        return "colour ramp [[position, colour], ...]"


# ------------------------------------------------------------------------------------- bound values
@dataclass
class Bound:
    """A continuous parameter as a graph uses it: initial value, element-wise range, whether fixed."""

    value: torch.Tensor
    lo: torch.Tensor
    hi: torch.Tensor
    fixed: bool = False
    u0: torch.Tensor = field(init=False)

    def __post_init__(self) -> None:
        self.u0 = to_unconstrained(self.value, self.lo, self.hi)

    def frozen(self) -> Bound:
        """The same value and range, fixed."""
        return Bound(self.value, self.lo, self.hi, fixed=True)

    def constrained(self, u: torch.Tensor | None) -> torch.Tensor:
        """The value for unconstrained ``u`` (the initial value when ``u`` is None or the param is fixed)."""
        if u is None or self.fixed:
            return self.value
        lo, hi = self.lo.to(u), self.hi.to(u)
        return lo + (hi - lo) * torch.sigmoid(u)


def to_unconstrained(value: torch.Tensor, lo: torch.Tensor, hi: torch.Tensor) -> torch.Tensor:
    """``u`` with ``lo + (hi - lo)·sigmoid(u) ≈ value`` (value clamped :data:`EPS` inside the range)."""
    span = (hi - lo).clamp_min(1e-12)
    t = ((value - lo) / span).clamp(EPS, 1.0 - EPS)
    return torch.log(t) - torch.log1p(-t)
