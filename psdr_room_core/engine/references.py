"""References ``"package.module:attribute"`` to stage functions and implementation factories, imported on first use.

A plugin may register a stage or an implementation by reference instead of by object, as entry points and
Hydra's ``_target_`` name their objects, so that loading the plugins imports none of the heavy libraries its
code needs (torch, Mitsuba): ``psdr-room --help`` and a fully cached run never import them. What the engine
must know before that, it reads from the module's source without running it: the module itself (for the code
fingerprint, :mod:`.fingerprint`) and the function's parameters (for the pipeline's input check).
"""

from __future__ import annotations

import ast
import functools
import importlib
import importlib.util
import inspect
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from .errors import PsdrRoomError

Target = Callable[..., Any] | str
"""A callable, or a reference ``"package.module:attribute"`` to one."""


@dataclass(frozen=True)
class Parameter:
    """One parameter of a stage function, as the input check needs it."""

    name: str
    keyword: bool
    """Whether it can be given by name (not positional-only, not ``*args``)."""
    required: bool
    """Whether it has no default."""
    var_keyword: bool = False
    """``**kwargs``: it takes any name."""


def module_of(target: Target) -> str:
    """The module that defines ``target`` (a reference's own, without importing it)."""
    if isinstance(target, str):
        return _split(target)[0]
    return str(getattr(target, "__module__", "") or "")


def load(target: Target) -> Callable[..., Any]:
    """``target`` itself, or the object its reference names, imported now (a failure is a one-line error)."""
    if not isinstance(target, str):
        return target
    module, attribute = _split(target)
    try:
        obj: Any = importlib.import_module(module)
        for part in attribute.split("."):
            obj = getattr(obj, part)
    except Exception as exc:
        raise PsdrRoomError(f"cannot load {target}: {type(exc).__name__}: {exc}") from None
    if not callable(obj):
        raise PsdrRoomError(f"{target} is a {type(obj).__name__}, not a function or class")
    return cast(Callable[..., Any], obj)


def docstring(target: Target) -> str:
    """The first line of ``target``'s docstring (a reference's read from its module's source)."""
    node = _definition(target) if isinstance(target, str) else None
    text = ast.get_docstring(node) if node is not None else inspect.getdoc(load(target))
    return (text or "").split("\n")[0]


def parameters(target: Target) -> list[Parameter]:
    """The parameters of function ``target``; a reference's read from its module's source when the name is a
    plain ``def`` there, else from the imported object."""
    node = _definition(target) if isinstance(target, str) else None
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
        return _ast_parameters(node.args)
    out = []
    for p in inspect.signature(load(target)).parameters.values():
        out.append(
            Parameter(
                p.name,
                keyword=p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY),
                required=p.default is inspect.Parameter.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD),
                var_keyword=p.kind is p.VAR_KEYWORD,
            )
        )
    return out


def module_file(module: str) -> Path | None:
    """The ``.py`` file of ``module`` found on the import path without importing it or its packages (None for
    a name that is not a module of source, such as a function imported with ``from package import function``)."""
    top, _, rest = module.partition(".")
    try:
        spec = importlib.util.find_spec(top)  # a top-level name: finding it runs no package code
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    if not rest:
        return Path(spec.origin) if spec.origin and spec.origin.endswith(".py") else None
    folders = [Path(p) for p in (spec.submodule_search_locations or [])]
    parts = rest.split(".")
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        found = None
        for folder in folders:
            if (folder / part / "__init__.py").is_file():
                found = folder / part
                break
            if last and (folder / f"{part}.py").is_file():
                return folder / f"{part}.py"
        if found is None:
            return None
        if last:
            return found / "__init__.py"
        folders = [found]
    return None


def _split(reference: str) -> tuple[str, str]:
    module, colon, attribute = reference.partition(":")
    if not (colon and module and attribute):
        raise ValueError(f"reference '{reference}' is not of the form 'package.module:attribute'")
    return module, attribute


def _definition(reference: str) -> ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef | None:
    """The top-level ``def`` or ``class`` statement of the reference's attribute in its module's source."""
    module, attribute = _split(reference)
    path = module_file(module)
    if path is None or "." in attribute:
        return None
    for node in _tree(path).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) and node.name == attribute:
            return node
    return None


@functools.cache
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_bytes(), filename=str(path))


def _ast_parameters(args: ast.arguments) -> list[Parameter]:
    positional = [*args.posonlyargs, *args.args]
    defaults = [False] * (len(positional) - len(args.defaults)) + [True] * len(args.defaults)
    out = [
        Parameter(a.arg, keyword=a not in args.posonlyargs, required=not d)
        for a, d in zip(positional, defaults, strict=True)
    ]
    out += [
        Parameter(a.arg, keyword=True, required=d is None)
        for a, d in zip(args.kwonlyargs, args.kw_defaults, strict=True)
    ]
    if args.kwarg is not None:
        out.append(Parameter(args.kwarg.arg, keyword=False, required=False, var_keyword=True))
    return out
