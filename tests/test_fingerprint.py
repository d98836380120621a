"""Code fingerprints: a stage's key follows the code it runs (its module and the project modules they import),
not their docstrings and comments, and a process parses only the modules whose bytes changed."""

from __future__ import annotations

import ast
import functools
import importlib
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from psdr_room_core.engine import fingerprint
from psdr_room_core.engine.fingerprint import _imports, code_fingerprint, code_modules
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.references import Target, module_file

PHYSICAL = "psdr_room_core.method.physical"


def new_process() -> None:
    """Forget what this process's fingerprints remember, as a new process after an upgrade does."""
    for cached in (
        fingerprint._fingerprint,
        fingerprint._closure,
        fingerprint._code_digest,
        fingerprint._source,
        fingerprint._imports,
        fingerprint._remembered,
    ):
        cached.cache_clear()


@pytest.fixture
def fresh(cache_dir: Path) -> Iterator[Path]:
    """A new process's fingerprints, with an empty table in a fresh cache directory (its path); forgotten after
    the test too (which may have pointed them at copies)."""
    new_process()
    yield cache_dir / fingerprint.TABLE
    new_process()


@pytest.fixture
def toy_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A package ``fp_toy`` on the import path: ``stage`` imports ``helper``; ``unrelated`` is imported by none."""
    package = tmp_path / "fp_toy"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "stage.py").write_text("from .helper import twice\n\n\ndef run(x):\n    return twice(x)\n")
    (package / "helper.py").write_text(
        '"""Helpers."""\n\nLABEL = "double"\n"""What the stage calls it."""\n'
        "def setting(default, *, ge, doc):\n    return default\n\n\n"
        'FACTOR = setting(2, ge=1, doc="What ``x`` is multiplied by.")\n\n\n'
        'def twice(x):\n    """Twice ``x``."""\n    return 2 * x  # exact\n'
    )
    (package / "unrelated.py").write_text("Y = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield package
    for name in ("fp_toy.stage", "fp_toy.helper", "fp_toy"):
        sys.modules.pop(name, None)


def test_a_stage_key_follows_its_own_code_only() -> None:
    """Changing only fit_appearance's module changes fit_appearance's fingerprint and no other stage's (export_scene
    then recomputes through its changed input digest); the renderer's own modules are in its fingerprint."""
    registry = plugin_system().registry
    own = registry.stages["fit_appearance"].fn.__module__
    for name, stage in registry.stages.items():
        assert (own in code_modules(stage.fn)) == (name == "fit_appearance"), name
        assert not [m for m in code_modules(stage.fn) if m.startswith("psdr_room_core.engine")]
    renderer = registry.implementation("renderer", "mitsuba")
    assert {"psdr_room_plugins.mitsuba_renderer.session", "psdr_room_plugins.mitsuba_renderer.integrator"} <= set(
        code_modules(renderer.factory)
    )


def test_fingerprint_follows_the_code_of_imported_modules(fresh: Path, toy_package: Path) -> None:
    """An imported module's code changes the fingerprint; its docstrings, attribute docstrings, settings' ``doc=``,
    comments and layout do not, nor does a module nobody imports; string data is code."""
    stage = importlib.import_module("fp_toy.stage")
    before = code_fingerprint(stage.run)
    assert code_modules(stage.run) == ["fp_toy.helper", "fp_toy.stage"]
    helper = toy_package / "helper.py"
    original = helper.read_text()
    edits = [
        ("unrelated.py", "Y = 2\n", False),
        ("helper.py", original.replace('"""Helpers."""', '"""Small helpers."""'), False),
        ("helper.py", original.replace('"""What the stage', '"""What the stage and the report'), False),
        ("helper.py", original.replace('"""Twice ``x``."""', '"""Twice ``x``, exactly."""'), False),
        ("helper.py", original.replace("# exact", "# exact: a float times two") + "\n\n# the end\n", False),
        ("helper.py", original.replace("\n\n\ndef", "\n\ndef").replace("2 * x", "2  *  x"), False),
        ("helper.py", original.replace("multiplied by.", "multiplied by, an integer."), False),
        ("helper.py", original.replace('LABEL = "double"', 'LABEL = "twice"'), True),
        ("helper.py", original.replace("ge=1", "ge=2"), True),
        ("helper.py", original.replace("2 * x", "x + x"), True),
    ]
    for file, text, differs in edits:
        (toy_package / file).write_text(text)
        new_process()
        assert (code_fingerprint(stage.run) != before) == differs, text
        helper.write_text(original)
    call = b'register(settings, doc="%s")\n'  # a doc= in a call that is a statement of its own
    assert fingerprint._code(call % b"One.") == fingerprint._code(call % b"Two.") != fingerprint._code(b"register()\n")


def _docstrings_reworded(source: str) -> str:
    """``source`` with a word added to every triple-quoted docstring (of the module, its classes and functions)."""
    lines = source.splitlines(keepends=True)
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and ast.get_docstring(
            node, clean=False
        ):
            first = node.body[0]
            line = lines[first.lineno - 1]
            start = line.find('"""', first.col_offset)
            if start >= 0:
                lines[first.lineno - 1] = line[: start + 3] + "Reworded: " + line[start + 3 :]
    return "".join(lines)


def _commented(source: str) -> str:
    """``source`` with a comment before every top-level statement and blank lines after it."""
    lines = source.splitlines(keepends=True)
    for node in reversed(ast.parse(source).body):
        lines.insert(node.lineno - 1, "# a remark on what follows\n")
        lines.insert(node.end_lineno or node.lineno, "\n")
    return "".join(lines)


def _fingerprints(targets: dict[str, Target]) -> dict[str, str]:
    new_process()
    return {name: code_fingerprint(target) for name, target in targets.items()}


def test_prose_of_a_module_changes_no_fingerprint_and_its_code_those_that_import_it(
    fresh: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a copy of method/physical.py: rewording its docstrings and adding comments and blank lines changes no
    stage's or implementation's fingerprint; a change of its code changes those of place_objects and fit_objects,
    and of every stage and implementation whose code imports it, and no other: not the stages before them."""
    registry = plugin_system().registry
    targets = {f"stage {name}": stage.target for name, stage in registry.stages.items()}
    targets |= {f"{c}={n}": impl.target for (c, n), impl in registry.implementations.items()}
    real = module_file(PHYSICAL)
    assert real is not None
    copy = tmp_path / "physical.py"
    shutil.copyfile(real, copy)
    source_of = fingerprint._source
    monkeypatch.setattr(
        fingerprint, "_source", functools.cache(lambda name: copy if name == PHYSICAL else source_of(name))
    )
    before = _fingerprints(targets)

    source = real.read_text(encoding="utf-8")
    reworded = _commented(_docstrings_reworded(source))
    assert reworded.count("Reworded: ") > 10 and reworded.count("# a remark") > 10
    copy.write_text(reworded, encoding="utf-8")
    assert _fingerprints(targets) == before

    copy.write_text(source + "\nSETTLE_MARGIN = 0.5\n", encoding="utf-8")
    after = _fingerprints(targets)
    importing = {name for name, target in targets.items() if PHYSICAL in code_modules(target)}
    assert {"stage place_objects", "stage fit_objects"} <= importing
    assert {name for name in targets if after[name] != before[name]} == importing
    stages_before = ("load_image", "estimate_fov", "segment", "point_cloud", "room_fit", "retrieve_objects")
    assert not importing & {f"stage {name}" for name in stages_before}  # the stages before keep theirs
    assert len(importing) < len(targets)  # the implementations that do not import it keep theirs


def test_a_new_process_parses_only_the_modules_whose_bytes_changed(
    fresh: Path, toy_package: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Code digests are remembered in the table against each module's bytes: a new process reads them from there
    and parses only a module that changed; an unreadable table is computed again."""
    stage = importlib.import_module("fp_toy.stage")
    before = code_fingerprint(stage.run)
    assert set(fingerprint._read_table(fresh)) == {str(toy_package / "helper.py"), str(toy_package / "stage.py")}
    parsed: list[bytes] = []
    code = fingerprint._code
    monkeypatch.setattr(fingerprint, "_code", lambda source: parsed.append(source) or code(source))

    new_process()
    assert code_fingerprint(stage.run) == before and parsed == []
    helper = toy_package / "helper.py"
    helper.write_text(helper.read_text().replace("2 * x", "x + x"))
    new_process()
    changed = code_fingerprint(stage.run)
    assert changed != before and parsed == [helper.read_bytes()]

    fresh.write_text("[not, a table")
    new_process()
    assert code_fingerprint(stage.run) == changed and len(parsed) == 3
    assert fingerprint._read_table(fresh)[str(helper)][1] == fingerprint._code_digest(helper)


def test_the_fingerprint_reads_every_import_statement(tmp_path: Path) -> None:
    """Imports at any depth, over several lines, after a comment's bracket; text that only reads like one
    (a docstring line) may count too: a fingerprint may cover a module more, never one less."""
    source = tmp_path / "mod.py"
    source.write_text(
        '"""Doc.\n\nfrom the top of the page\n"""\nimport a.b\nfrom .sibling import (\n    one,\n    two,\n)\n\n'
        "def f():\n    if True:\n        from c import d  # (see e\n    import g, h as i\n"
    )
    found = set(_imports("pkg.mod", source))
    assert {"a.b", "pkg.sibling", "pkg.sibling.one", "pkg.sibling.two", "c", "c.d", "g", "h"} <= found
