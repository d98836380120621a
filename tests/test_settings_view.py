"""``psdr-room --settings NODE``: each setting of a stage or an implementation with its value and meaning."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from psdr_room_core.engine.cli import main


@pytest.fixture(autouse=True)
def empty_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)


def shown(*args: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The lines ``psdr-room ARGS`` prints, run in an empty folder that it must leave empty."""
    monkeypatch.setattr(sys, "argv", ["psdr-room", *args])
    main()
    assert not list(Path.cwd().iterdir())
    return capsys.readouterr().out.splitlines()


def test_a_stage_node_with_values_meanings_and_nesting(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = shown("--settings", "place_objects", monkeypatch=monkeypatch, capsys=capsys)
    assert lines[0].startswith("place_objects:  # ``place_objects`` (§4.3")
    assert "  render_width = 160  # Silhouettes are compared at this width, pixels." in lines
    search = lines.index(next(line for line in lines if line.startswith("  search:  # ")))
    assert lines[search + 1].startswith("    n_yaw = 12  # ")
    assert all(" = " in line or line.rstrip().endswith(":") or ":  # " in line for line in lines[1:])


def test_overrides_and_implementations(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    lines = shown("--settings=renderer.mitsuba", "renderer.mitsuba.spp=7", monkeypatch=monkeypatch, capsys=capsys)
    assert lines[0].startswith("renderer.mitsuba:  # ")
    assert any(line.startswith("  spp = 7  # ") for line in lines)
    nodes = shown("--settings", monkeypatch=monkeypatch, capsys=capsys)
    assert nodes[0] == "settings nodes (psdr-room --settings NODE):"
    assert {"  place_objects", "  segmentation.layout", "  renderer.mitsuba"} <= set(nodes)


def test_an_unknown_node_is_one_line_with_the_closest(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(sys, "argv", ["psdr-room", "--settings", "segmentation.layou"])
    with pytest.raises(SystemExit) as exit_:
        main()
    error = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and len(error.splitlines()) == 1
    assert "no settings node of that name (did you mean segmentation.layout?)" in error
