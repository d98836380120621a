"""Fingerprints of the code a stage or an implementation runs, for its cache key.

A stage's key holds its declared ``version`` and, so that nobody has to remember to bump it, a digest of the
source of the module defining its function and of every module it imports from the same project, followed
through their imports (read statically from the source, as Hamilton fingerprints a DAG's functions). An upgrade
then recomputes the stages whose code changed, and the stages after them whose inputs changed, and serves the
rest from the cache. The project of a module is its top-level package, plus the method's and the built-in
plugins' packages (a plugin building on the method's helpers computes with them). Left out: the engine
(:mod:`psdr_room_core.engine` runs stages and computes none of their results; its cache format has its own
``SCHEMA``), and third-party libraries, whose versions are the environment's business (after upgrading
Mitsuba, rerun with ``cache=off`` or a new ``cache_dir``).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import sys
from collections.abc import Iterator
from pathlib import Path

from .references import Target, module_file, module_of

FOLLOWED = ("psdr_room_core", "psdr_room_plugins")
"""Packages whose modules are followed from any plugin's code ..."""
NOT_FOLLOWED = "psdr_room_core.engine"
"""... but for the engine's."""


def code_fingerprint(target: Target) -> str:
    """Digest of the source of ``target``'s module and the project modules it imports, transitively (read from
    the files: nothing is imported)."""
    module = module_of(target)
    return _fingerprint(module) if _source(module) is not None else "unknown"


def code_modules(target: Target) -> list[str]:
    """The modules whose source :func:`code_fingerprint` digests for ``target``."""
    module = module_of(target)
    return sorted(_closure(module)) if _source(module) is not None else []


@functools.cache
def _fingerprint(module: str) -> str:
    digest = hashlib.sha256()
    for name, path in sorted(_closure(module).items()):
        digest.update(name.encode() + b"\0" + _file_digest(path).encode())
    return digest.hexdigest()


@functools.cache
def _closure(module: str) -> dict[str, Path]:
    project = (module.split(".")[0], *FOLLOWED)
    seen: dict[str, Path] = {}
    todo = [module]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        path = _source(name)
        if path is None:
            continue
        seen[name] = path
        todo.extend(
            n for n in _imports(name, path) if n.split(".")[0] in project and not _is_engine(n) and n not in seen
        )
    return seen


def _is_engine(name: str) -> bool:
    return name == NOT_FOLLOWED or name.startswith(NOT_FOLLOWED + ".")


@functools.cache
def _source(name: str) -> Path | None:
    """The ``.py`` file of module ``name`` (None for a name that is not a module, such as a function imported
    with ``from package import function``), found without importing anything."""
    loaded = sys.modules.get(name)
    file = getattr(loaded, "__file__", None) if loaded is not None else None
    if file is None:
        return module_file(name)
    return Path(file) if file.endswith(".py") else None


@functools.cache
def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@functools.cache
def _imports(name: str, path: Path) -> list[str]:
    """Modules ``name`` (at ``path``) imports: ``import a.b`` gives ``a.b``; ``from .x import y`` gives ``x``
    resolved against the package, and ``x.y`` in case ``y`` is a module."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: list[str] = []
    for node in _import_statements(path.read_text(encoding="utf-8")):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1])
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            found.append(target)
            found += [f"{target}.{alias.name}" for alias in node.names if alias.name != "*"]
    return found


def _import_statements(source: str) -> Iterator[ast.Import | ast.ImportFrom]:
    """The import statements of a module's source at any depth (in functions, classes and blocks), each parsed
    alone from the lines that start with ``import`` or ``from`` (a tenth of the time of parsing the module). A
    docstring line that reads as an import counts too: the fingerprint then covers a module more, never less."""
    lines = source.splitlines()
    i = 0
    while i < len(lines):
        first = lines[i].lstrip()
        i += 1
        if not first.startswith(("import ", "from ")):
            continue
        statement, end = first, i
        while (statement.count("(") > statement.count(")") or statement.endswith("\\")) and end < len(lines):
            statement, end = statement + "\n" + lines[end], end + 1
        for text, after in ((statement, end), (first, i)):  # a comment's bracket can spoil the joined lines
            try:
                nodes = ast.parse(text).body
            except SyntaxError:
                continue
            yield from (n for n in nodes if isinstance(n, ast.Import | ast.ImportFrom))
            i = after
            break
