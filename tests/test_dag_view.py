"""``psdr-room --dag``: the composed config's pipeline as text or a Mermaid flowchart, without running anything."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from psdr_room_core.engine.cli import main

REPO = Path(__file__).resolve().parents[1]

STAGES = [
    "load_image() -> image",
    "estimate_fov(image) -> camera",
    "detect(image) -> detections",
    "segment(image, camera, detections) -> panoptic",
    "estimate_depth(image, camera, panoptic) -> depth",
    "point_cloud(image, camera, depth, panoptic) -> point_cloud",
    "room_init(cloud=point_cloud) -> room_box",
    "room_fit(room=room_box, camera, depth, panoptic, image) -> room_box_fit, camera_fit, room_fit_log",
    "group_objects(image, panoptic, cloud=point_cloud, camera=camera_fit, room=room_box_fit, depth)"
    " -> panoptic_grouped, point_cloud_grouped",
    "retrieve_objects(image, panoptic=panoptic_grouped, cloud=point_cloud_grouped, camera=camera_fit,"
    " room=room_box_fit) -> object_candidates",
    "place_objects(candidates=object_candidates, image, panoptic=panoptic_grouped, cloud=point_cloud_grouped,"
    " camera=camera_fit, room=room_box_fit) -> placements",
    "fit_objects(placements, camera=camera_fit, room=room_box_fit, depth, panoptic=panoptic_grouped, image)"
    " -> placements_fit, fit_objects_log, room_box_objects",
    "assign_materials(image, panoptic=panoptic_grouped, camera=camera_fit, room=room_box_objects,"
    " placements=placements_fit) -> materials",
    "init_lights(image, panoptic=panoptic_grouped, camera=camera_fit, room=room_box_objects,"
    " placements=placements_fit, materials) -> lights",
    "fit_appearance(image, camera=camera_fit, room=room_box_objects, placements=placements_fit, materials, lights)"
    " -> appearance, fit_appearance_log",
    "export_scene(camera=camera_fit, room=room_box_objects, cloud=point_cloud_grouped, placements=placements_fit,"
    " lights, appearance) -> scene",
]


def dag(*args: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> str:
    """What ``psdr-room ARGS`` prints, run in an empty folder that it must leave empty."""
    monkeypatch.setattr(sys, "argv", ["psdr-room", *args])
    main()
    assert not list(Path.cwd().iterdir())
    return capsys.readouterr().out


@pytest.fixture(autouse=True)
def empty_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)


def stanzas(text: str) -> dict[str, list[str]]:
    """Each stage's line of ``--dag`` → the lines indented under it."""
    out: dict[str, list[str]] = {}
    for line in text.splitlines():
        if line.startswith("    "):
            out[next(reversed(out))].append(line.strip())
        else:
            out[line] = []
    return out


def test_every_stage_in_run_order_with_its_inputs_outputs_and_implementations(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """No photo is needed; each input is named by its parameter, with the artifact feeding it where they differ."""
    shown = stanzas(dag("--dag", monkeypatch=monkeypatch, capsys=capsys))
    assert list(shown) == STAGES
    assert shown[STAGES[1]] == ["fov: vanishing_points"]
    assert shown[STAGES[2]] == ["detector: auto (the first usable of boxes_file, nanodet_eyes, nanodet_onnx)"]
    assert shown[STAGES[0]] == shown[STAGES[6]] == []
    assert "texture: random_cnn with size=128" in shown[STAGES[14]]  # its _uses_
    assert "texture: random_cnn" in shown[STAGES[12]]


def test_overrides_change_what_it_shows(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    shown = stanzas(dag("--dag", "detector=none", "~export_scene", monkeypatch=monkeypatch, capsys=capsys))
    assert list(shown) == STAGES[:-1] and shown[STAGES[2]] == ["detector: none"]
    shown = stanzas(dag("--dag", "~segment", "+inject.panoptic=DIR", monkeypatch=monkeypatch, capsys=capsys))
    assert list(shown) == ["given: panoptic (inject.panoptic)", *STAGES[:3], *STAGES[4:]]


def test_a_form_it_does_not_know_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        dag("--dag=dot", monkeypatch=monkeypatch, capsys=capsys)
    assert exited.value.code == 2
    assert capsys.readouterr().err == (
        "psdr-room: error: --dag=dot is not a form of the graph; use --dag (text) or --dag=mermaid\n"
    )


NODE = re.compile(r'^    (s\d+)\["([^"]*)"\]$')
EDGE = re.compile(r'^    (s\d+|given\d+) -->\|"([^"]*)"\| (s\d+)$')
GIVEN = re.compile(r'^    (given\d+)\(\["([^"]*)"\]\)$')


@pytest.mark.parametrize("form", [("--dag=mermaid",), ("--dag", "mermaid")])
def test_the_mermaid_flowchart_has_a_box_per_stage_and_an_arrow_per_artifact_read(
    form: tuple[str, ...], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    header, *lines = dag(*form, "~segment", "+inject.panoptic=DIR", monkeypatch=monkeypatch, capsys=capsys).splitlines()
    assert header == "flowchart TD"
    nodes = {m[1]: m[2].split("<br/>") for m in map(NODE.match, lines) if m}
    given = {m[1]: m[2] for m in map(GIVEN.match, lines) if m}
    edges = [(m[1], m[2].split(", "), m[3]) for m in map(EDGE.match, lines) if m]
    assert len(nodes) + len(given) + len(edges) == len(lines)
    names = {node: label[0] for node, label in nodes.items()} | {node: "inject" for node in given}
    stages = [stage for stage in STAGES if not stage.startswith("segment(")]
    assert [names[n] for n in nodes] == [stage.split("(")[0] for stage in stages] and given == {"given0": "panoptic"}
    assert nodes["s13"][1:] == [
        "renderer: mitsuba",
        "optimizer: adam",
        "material_graph: torch_graph",
        "texture: random_cnn with size=128",
        "denoiser: oidn",
    ]
    read = {(names[a], artifact, names[b]) for a, artifacts, b in edges for artifact in artifacts}
    assert ("room_fit", "camera_fit", "fit_objects") in read and ("room_fit", "room_box_fit", "fit_objects") in read
    assert ("inject", "panoptic", "estimate_depth") in read and ("inject", "panoptic", "room_fit") in read
    assert len({(a, b) for a, _, b in edges}) == len(edges)  # one arrow per pair of stages, all it reads on it
    for stage in stages:
        name, inputs = stage.split("(")[0], stage.split("(")[1].split(")")[0]
        wanted = {i.split("=")[-1] for i in inputs.split(", ") if i}
        assert {artifact for _, artifact, b in read if b == name} == wanted


def test_the_docs_show_the_pipeline_as_it_is(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/pipeline.md holds what ``psdr-room --dag`` and ``--dag=mermaid`` print."""
    page = (REPO / "docs" / "pipeline.md").read_text()
    blocks = re.findall(r"```(text|mermaid)\n(.*?)```", page, flags=re.S)
    assert [form for form, _ in blocks] == ["text", "mermaid"]
    assert blocks[0][1] == dag("--dag", monkeypatch=monkeypatch, capsys=capsys)
    assert blocks[1][1] == dag("--dag=mermaid", monkeypatch=monkeypatch, capsys=capsys)
