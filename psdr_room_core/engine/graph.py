"""The stage graph: stage nodes wired by the artifacts they consume and produce, sorted topologically, checked
against their functions and sliced (kedro-style ``run.only``, ``run.from``, ``run.until``)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from . import references
from .errors import PsdrRoomError
from .registry import Registry
from .stage_config import StageNode, stage_nodes


def check_stage_inputs(nodes: Iterable[StageNode], registry: Registry) -> None:
    """Check each stage node's ``_inputs_`` against its function's parameters (``fn(ctx, **inputs)``) when the
    pipeline is built, as kedro checks a node's inputs when the node is made: an input the function does not take,
    or a parameter without a default that no input gives, is a one-line :class:`PsdrRoomError` (stage, input,
    expected, found) before any stage runs."""
    for node in nodes:
        stage = registry.stage(node.function)
        parameters = references.parameters(stage.target)[1:]  # after ctx; a reference's read from its source
        if any(p.var_keyword for p in parameters):
            continue
        takes = [p.name for p in parameters if p.keyword]
        needed = [p.name for p in parameters if p.required and p.keyword]
        expected = f"expected {', '.join(takes) or 'none'} (stage function {node.function})"
        for name in node.inputs:
            if name not in takes:
                raise PsdrRoomError(
                    f"stage '{node.name}': input '{name}' is not a parameter of its function; "
                    f"{expected}, found {', '.join(node.inputs)}; fix {node.name}._inputs_"
                )
        for name in needed:
            if name not in node.inputs:
                raise PsdrRoomError(
                    f"stage '{node.name}': no input for parameter '{name}'; {expected}, found "
                    f"{', '.join(node.inputs) or 'none'}; add it to {node.name}._inputs_"
                )


@dataclass(frozen=True)
class Selection:
    """The stages a run considers (in order) and those it recomputes even if cached."""

    stages: list[StageNode]
    forced: frozenset[str]


class Pipeline:
    """Stage nodes sorted topologically by the artifacts they consume and produce. A stage whose every output is
    ``provided`` (given with ``+inject.NAME=DIR``) is replaced by what was given: it does not run."""

    def __init__(self, nodes: Iterable[StageNode], provided: Iterable[str] = ()) -> None:
        self.provided = set(provided)
        nodes = [node for node in nodes if not self._replaced(node)]
        self.producer: dict[str, StageNode] = {}
        for node in nodes:
            for artifact in node.outputs.values():
                if artifact in self.producer:
                    raise PsdrRoomError(
                        f"artifact '{artifact}' is produced by both stages '{self.producer[artifact].name}' and "
                        f"'{node.name}'; remove one of them from the config"
                    )
                self.producer[artifact] = node
        self.nodes = self._sorted(list(nodes))

    def _replaced(self, node: StageNode) -> bool:
        given = [a for a in node.outputs.values() if a in self.provided]
        missing = [a for a in node.outputs.values() if a not in self.provided]
        if given and missing:
            raise PsdrRoomError(
                f"inject.{given[0]} is given but stage '{node.name}' also computes {', '.join(missing)}; give "
                f"those too (+inject.{missing[0]}=DIR) or none of its outputs"
            )
        return bool(given)

    @classmethod
    def from_config(cls, cfg: Mapping[str, Any], provided: Iterable[str] = ()) -> Pipeline:
        """Build the pipeline from the composed config's stage nodes (:mod:`.stage_config`)."""
        return cls(stage_nodes(cfg), provided)

    def _sorted(self, nodes: list[StageNode]) -> list[StageNode]:
        for node in nodes:
            for artifact in node.inputs.values():
                if artifact not in self.producer and artifact not in self.provided:
                    raise PsdrRoomError(
                        f"stage '{node.name}' needs artifact '{artifact}' but no stage produces it; "
                        f"add the producing stage or give it with +inject.{artifact}=DIR"
                    )
        order: list[StageNode] = []
        done: set[str] = set()
        pending = list(nodes)
        while pending:  # the first stage in config order whose inputs are ready, one at a time
            ready = next((n for n in pending if all(self._available(a, done) for a in n.inputs.values())), None)
            if ready is None:
                raise PsdrRoomError(f"the stages {', '.join(n.name for n in pending)} form a cycle; fix their _inputs_")
            order.append(ready)
            done.add(ready.name)
            pending.remove(ready)
        return order

    def _available(self, artifact: str, done: set[str]) -> bool:
        return artifact in self.provided or self.producer[artifact].name in done

    def node(self, name: str) -> StageNode:
        for node in self.nodes:
            if node.name == name:
                return node
        raise PsdrRoomError(f"no stage '{name}' in the pipeline; stages: {', '.join(n.name for n in self.nodes)}")

    def upstream(self, name: str) -> set[str]:
        """Names of the stages ``name`` depends on, transitively (excluding itself)."""
        found: set[str] = set()
        stack = [self.node(name)]
        while stack:
            for artifact in stack.pop().inputs.values():
                producer = self.producer.get(artifact)
                if producer is not None and artifact not in self.provided and producer.name not in found:
                    found.add(producer.name)
                    stack.append(producer)
        return found

    def downstream(self, name: str) -> set[str]:
        """Names of the stages that depend on ``name``, transitively (excluding itself)."""
        return {n.name for n in self.nodes if name in self.upstream(n.name)}

    def select(self, only: str | None = None, start: str | None = None, until: str | None = None) -> Selection:
        """Slice the pipeline (kedro-style): ``until`` keeps a stage and what it needs; ``start`` recomputes
        a stage and everything after it; ``only`` recomputes one stage. Upstream outputs come from the cache
        (or are computed when missing)."""
        if only is not None and (start is not None or until is not None):
            raise PsdrRoomError("run.only cannot be combined with run.from or run.until; use one or the other")
        keep = {n.name for n in self.nodes}
        forced: set[str] = set()
        if only is not None:
            keep = self.upstream(only) | {only}
            forced = {only}
        if start is not None:
            forced = self.downstream(start) | {start}
            keep = set().union(*(self.upstream(n) | {n} for n in forced))
        if until is not None:
            keep &= self.upstream(until) | {until}
            forced &= keep
        return Selection(stages=[n for n in self.nodes if n.name in keep], forced=frozenset(forced))
