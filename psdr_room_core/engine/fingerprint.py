"""Fingerprints of the code a stage or an implementation runs, for its cache key.

A stage's key holds its declared ``version`` and, so that nobody has to remember to bump it, a digest of the
code of the module defining its function and of every module it imports from the same project, followed
through their imports (read statically from the source, as Hamilton fingerprints a DAG's functions). An upgrade
then recomputes the stages whose code changed, and the stages after them whose inputs changed, and serves the
rest from the cache. The project of a module is its top-level package, plus the method's and the built-in
plugins' packages (a plugin building on the method's helpers computes with them). Left out: the engine
(:mod:`psdr_room_core.engine` runs stages and computes none of their results; its cache format has its own
``SCHEMA``), and third-party libraries, whose versions are the environment's business (after upgrading
Mitsuba, rerun with ``cache=off`` or a new ``cache_dir``).

A module's digest is of its code, not its prose: of its syntax tree (:func:`ast.dump`, which holds no comments,
layout or line numbers) without the statements that are a string alone: docstrings, and the attribute docstrings
after an assignment (which Python discards), and without the ``doc="..."`` keyword arguments that give a setting its
meaning (:func:`psdr_room_core.engine.settings.setting`). Fixing a typo in a docstring, a comment or a setting's
doc recomputes nothing; other string data (a value, an argument) is code. The tree's form is Python's own, so a new Python version recomputes
everything once. Parsing every module a pipeline runs takes about a second, so each module's code digest is
remembered against the digest of its bytes in :data:`TABLE` in psdr-room's cache directory
(``$PSDR_ROOM_CACHE_DIR``, else ``~/.cache/psdr-room``): a process parses only the modules whose bytes changed
since (where the table cannot be written, every process parses them).
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path

from .cache import default_cache_dir
from .files import write_whole
from .references import Target, module_file, module_of

FOLLOWED = ("psdr_room_core", "psdr_room_plugins")
"""Packages whose modules are followed from any plugin's code ..."""
NOT_FOLLOWED = "psdr_room_core.engine"
"""... but for the engine's."""
TABLE = f"code-digests-v1-py{sys.version_info.major}.{sys.version_info.minor}.json"
"""The file remembering code digests: module path → [digest of its bytes, digest of its code] (its ``v1`` is
counted up whenever :func:`_code` changes what it keeps)."""

_LEARNT: dict[str, tuple[str, str]] = {}
"""The code digests this process computed that :data:`TABLE` does not hold yet, as it would hold them."""


def code_fingerprint(target: Target) -> str:
    """Digest of the code of ``target``'s module and the project modules it imports, transitively (read from
    the files: nothing is imported)."""
    module = module_of(target)
    return _fingerprint(module) if _source(module) is not None else "unknown"


def code_modules(target: Target) -> list[str]:
    """The modules whose code :func:`code_fingerprint` digests for ``target``."""
    module = module_of(target)
    return sorted(_closure(module)) if _source(module) is not None else []


@functools.cache
def _fingerprint(module: str) -> str:
    digest = hashlib.sha256()
    for name, path in sorted(_closure(module).items()):
        digest.update(name.encode() + b"\0" + _code_digest(path).encode())
    _remember_learnt()
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
def _code_digest(path: Path) -> str:
    """Digest of the code of the module at ``path`` (see the module's docstring): remembered in :data:`TABLE`
    for its bytes, or computed."""
    source = path.read_bytes()
    source_digest = hashlib.sha256(source).hexdigest()
    remembered = _remembered().get(str(path))
    if remembered is not None and remembered[0] == source_digest:
        return remembered[1]
    code_digest = hashlib.sha256(_code(source).encode()).hexdigest()
    _LEARNT[str(path)] = (source_digest, code_digest)
    return code_digest


def _code(source: bytes) -> str:
    """The canonical form of a module's code: its syntax tree without the statements that are a string alone
    (a source Python cannot parse, which no import could run either, is its own form)."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return source.hex()
    return ast.dump(_WithoutProse().visit(tree))


class _WithoutProse(ast.NodeTransformer):
    """Drops every statement that is a string constant alone (a docstring, or an attribute docstring) and every
    ``doc="..."`` keyword argument (a setting's meaning, :func:`psdr_room_core.engine.settings.setting`)."""

    def visit_Expr(self, node: ast.Expr) -> ast.Expr | None:
        return None if _is_text(node.value) else self.generic_visit(node)  # type: ignore[return-value]

    def visit_keyword(self, node: ast.keyword) -> ast.keyword | None:
        return None if node.arg == "doc" and _is_text(node.value) else node


def _is_text(node: ast.expr) -> bool:
    return isinstance(node, ast.Constant) and isinstance(node.value, str)


@functools.cache
def _remembered() -> dict[str, tuple[str, str]]:
    """The code digests :data:`TABLE` holds, read once per process."""
    return _read_table(default_cache_dir() / TABLE)


def _read_table(file: Path) -> dict[str, tuple[str, str]]:
    """The entries of a table file that are as :func:`_remember_learnt` writes them (none of an unreadable file)."""
    try:
        table = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(table, dict):
        return {}
    return {
        path: (entry[0], entry[1])
        for path, entry in table.items()
        if isinstance(entry, list) and len(entry) == 2 and all(isinstance(part, str) for part in entry)
    }


def _remember_learnt() -> None:
    """Add the code digests this process computed to :data:`TABLE`, over what is there now (another process may
    have added its own), keeping the entries of files that still exist."""
    if not _LEARNT:
        return
    file = default_cache_dir() / TABLE
    table = {**_read_table(file), **_LEARNT}
    kept = {path: list(entry) for path, entry in sorted(table.items()) if Path(path).is_file()}
    _LEARNT.clear()
    with contextlib.suppress(OSError):  # a read-only cache directory: the next process computes them again
        write_whole(file, json.dumps(kept, indent=0))


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
