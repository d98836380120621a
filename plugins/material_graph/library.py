"""``material_graph=torch_graph``: the library of procedural materials and the node types they may use.

Graphs come from the built-in ``library/`` directory, then from directories plugins return from the
``material_graphs`` hook, then from ``extra_dirs`` in the config; node types from :mod:`.nodes` plus the
``material_nodes`` hook. A graph name (file stem) or node type name that is already taken is reported in a
warning and left out, so a plugin cannot silently replace a built-in. Graphs are parsed and validated on
first use and cached.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

from psdr_room_core.engine.errors import PsdrRoomError

from .graph import GRAPH_SUFFIXES, ProceduralMaterial, load_graph
from .nodes import KINDS, NodeType, builtin_node_types
from .nodes.ops import sample_periodic
from .thumbnails import shade

log = logging.getLogger(__name__)

LIBRARY_DIR = Path(__file__).with_name("library")


def _plugin_results(hook_name: str) -> list[Any]:
    from psdr_room_core.engine.plugins import plugin_system

    results: list[Any] = []
    for result in getattr(plugin_system().hook, hook_name)():
        if result is None:
            continue
        results.extend(result if isinstance(result, (list, tuple)) else [result])
    return results


class TorchGraphLibrary:
    """Procedural node-graph materials evaluated with torch (differentiable w.r.t. their parameters)."""

    def __init__(self, extra_dirs: Sequence[str] = (), use_plugins: bool = True, device: str = "cpu") -> None:
        """The settings are :class:`~psdr_room_plugins.material_graph.TorchGraphSettings`'
        (``material_graph.torch_graph.*``)."""
        self.device = str(device)
        self.node_types: dict[str, NodeType] = builtin_node_types()
        dirs: list[Path] = [LIBRARY_DIR]
        if use_plugins:
            for extra in _plugin_results("material_nodes"):
                self._add_node_type(extra)
            dirs += [Path(d) for d in _plugin_results("material_graphs")]
        dirs += [Path(d).expanduser() for d in extra_dirs]
        self.dirs = dirs
        self.files = self._index(dirs)
        self._cache: dict[str, ProceduralMaterial] = {}
        self._looks: dict[tuple[str, int], torch.Tensor] = {}

    def _add_node_type(self, node_type: Any) -> None:
        if not isinstance(node_type, NodeType) or node_type.kind not in KINDS:
            log.warning("psdr-room: material_nodes returned %r, not a NodeType; left out", node_type)
        elif node_type.name in self.node_types:
            log.warning(
                "psdr-room: material node type '%s' is already defined; the plugin's is left out", node_type.name
            )
        else:
            self.node_types[node_type.name] = node_type

    @staticmethod
    def _index(dirs: Iterable[Path]) -> dict[str, Path]:
        files: dict[str, Path] = {}
        for directory in dirs:
            if not directory.is_dir():
                raise PsdrRoomError(
                    f"{directory}: material graph directory not found; fix "
                    "material_graph.torch_graph.extra_dirs (or the plugin returning it)"
                )
            for path in sorted(p for p in directory.iterdir() if p.suffix in GRAPH_SUFFIXES):
                if path.stem in files:
                    log.warning(
                        "psdr-room: material graph '%s' of %s is already defined by %s; left out",
                        path.stem,
                        path,
                        files[path.stem],
                    )
                    continue
                files[path.stem] = path
        return files

    # ----------------------------------------------------------------------------- the protocol
    def names(self) -> list[str]:
        """Every material name, sorted."""
        return sorted(self.files)

    def material(self, name: str) -> ProceduralMaterial:
        """The validated graph called ``name`` (a one-line error listing the names when unknown)."""
        if name not in self.files:
            raise PsdrRoomError(
                f"unknown material '{name}'; known: {', '.join(self.names())} (psdr-room-materials list)"
            )
        if name not in self._cache:
            self._cache[name] = load_graph(self.files[name], self.node_types)
        return self._cache[name]

    def materials(self) -> list[ProceduralMaterial]:
        """Every material, validated (raises on the first invalid file)."""
        return [self.material(n) for n in self.names()]

    def appearance(self, name: str, size: int, values: Mapping[str, Any] | None = None) -> torch.Tensor:
        """sRGB [3, size, size] of material ``name`` at its own parameter values (or at ``values``: ``node.param``
        → value, clamped to its range; the others its own), head-on under the thumbnail light
        (:func:`.thumbnails.shade`): what material retrieval and the texture-transform search compare, and what the
        studio shows of a material being edited."""
        if values is not None:
            graph = self.material(name)
            with torch.no_grad():
                return shade(graph.evaluate(int(size), graph.unconstrained(values), device=self.device)).cpu()
        key = (name, int(size))
        if key not in self._looks:
            with torch.no_grad():
                self._looks[key] = shade(self.material(name).evaluate(int(size), device=self.device)).cpu()
        return self._looks[key]

    @staticmethod
    def sample(image: torch.Tensor, u: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        """Bilinear samples [C, H', W'] of a tileable image [C, H, W] at texture coordinates ``u``, ``v``
        (1 = one tile, wrapped), differentiable."""
        return sample_periodic(image, u, v)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import MaterialGraph

    _TorchGraphLibrary_is_a_material_graph: type[MaterialGraph] = TorchGraphLibrary
