"""The studio's web page: viser's GUI panel and 3D canvas over a :class:`~.session.Session`.

Every control calls one session method; a wrong value gets a one-line message in the page (the session
checked it before changing anything). Runs happen on a worker thread, with the stage events shown live.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
import torch
import viser

from psdr_room_core.applications.edit import load_state
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.records import first_artifact
from psdr_room_core.libraries.object_db import CATEGORIES as DB_CATEGORIES
from psdr_room_core.method.artifacts import (
    CATEGORIES,
    Camera,
    Candidate,
    Image,
    ObjectCandidates,
    Panoptic,
    Placements,
    RoomBox,
)
from psdr_room_core.method.shading import linear_to_srgb, srgb_to_linear
from psdr_room_core.method.view_search import ERROR_TERMS
from psdr_room_core.method.visualize import segment_overlay
from psdr_room_plugins.detectors.boxes_file import photo_scale, scaled
from psdr_room_plugins.layout.objects import grabcut_mask
from psdr_room_plugins.material_graph.thumbnails import tensor_to_uint8

from .scene_view import SceneView, overview, screen_to_photo
from .session import EDITED, PREVIEW, Session, StageEvent

THUMB = 112
"""Side of a candidate thumbnail in the page (pixels)."""
LOOK = 128
"""Side of the edited part's material look in the page (pixels)."""
PHOTO_WIDTH = 1200
"""Width of the photo panel's picture (pixels): shown at the panel's width, and this sharp when expanded."""
PHOTO_TEXT = 1.2
"""OpenCV text scale of its captions: legible at the panel's width (about 360 pixels)."""
Box = tuple[float, float, float, float]


def plain(text: str) -> str:
    """``text`` shown as written in a markdown element (ids and paths hold ``_`` and ``*``)."""
    return "".join(f"\\{c}" if c in "\\`*_[]<>#|" else c for c in text)


def draw_boxes(
    photo: np.ndarray,
    boxes: list[tuple[str, Box]],
    colour: tuple[int, int, int] = (255, 200, 0),
    text_scale: float = 0.45,
) -> np.ndarray:
    """``photo`` with each (caption, box in its pixels) drawn in ``colour`` and captioned (OpenCV's ``text_scale``)."""
    out = photo.copy()
    grow = text_scale / 0.45
    for caption, (x0, y0, x1, y1) in boxes:
        cv2.rectangle(out, (int(x0), int(y0)), (int(x1), int(y1)), colour, max(2, round(2 * grow)))
        at = (int(x0) + round(3 * grow), int(y0) + round(14 * grow))
        for ink, width in (((255, 255, 255), max(2, round(2 * grow))), ((0, 0, 0), max(1, round(grow)))):
            cv2.putText(out, caption, at, cv2.FONT_HERSHEY_SIMPLEX, text_scale, ink, width, cv2.LINE_AA)
    return out


def thumbnail_strip(images: list[np.ndarray], captions: list[str]) -> np.ndarray:
    """Candidate thumbnails side by side, each captioned (rank and score)."""
    tiles = []
    for image, caption in zip(images, captions):
        tile = cv2.resize(image, (THUMB, THUMB), interpolation=cv2.INTER_AREA)
        cv2.putText(tile, caption, (4, THUMB - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        tiles.append(cv2.copyMakeBorder(tile, 2, 2, 2, 2, cv2.BORDER_CONSTANT, value=(255, 255, 255)))
    return np.concatenate(tiles, axis=1) if tiles else np.full((THUMB, THUMB, 3), 255, np.uint8)


def score_table(ranked: list[Candidate]) -> str:
    """The candidates' scores term by term, as a markdown table (a column per candidate, to fit the panel): why each
    model ranks where it does."""
    given = {name for c in ranked for name in c.terms}
    names = [n for n in ("iou", *ERROR_TERMS) if n in given] + sorted(given - {"iou", *ERROR_TERMS})
    if not names:
        return ""
    rows = [
        f"| {name} | " + " | ".join(f"{c.terms[name]:.2f}" if name in c.terms else "" for c in ranked) + " |"
        for name in names
    ]
    return "\n".join(
        [
            "Score = 1 / (1 + the terms below `iou`, lower is better); `iou`: how much of the mask the posed model "
            "covers; " + "; ".join(f"`{n}`: {ERROR_TERMS[n]}" for n in names if n in ERROR_TERMS) + ".",
            "",
            "| rank | " + " | ".join(str(rank) for rank in range(len(ranked))) + " |",
            "|---" * (1 + len(ranked)) + "|",
            "| score | " + " | ".join(f"{c.score:.3f}" for c in ranked) + " |",
            *rows,
        ]
    )


def slider_step(lo: float, hi: float) -> float:
    """A slider step of about a hundredth of ``[lo, hi]``, rounded to one significant digit."""
    span = max(hi - lo, 1e-6) / 100.0
    return float(f"{span:.0e}")


class StudioApp:
    """The page: status line, run buttons and stage progress, the photo with its segmentation, boxes and crop
    windows, segment marks, object boxes (draw, delete, relabel), crop windows (move, add, delete), candidate picks
    and the edits of the exported scene (materials, graph parameters, lights, field of view), over a 3D view of the
    latest run."""

    def __init__(self, session: Session, server: viser.ViserServer, database: Any, library: Any) -> None:
        self.session = session
        self.server = server
        self.database = database
        self.library = library
        self.view = SceneView(server)
        self.progress: dict[str, StageEvent] = {}
        self.mask: np.ndarray | None = None
        self.drawing: Callable[[Any], None] | None = None
        """The rectangle callback of the drawing mode, while it is on."""
        self.initial_fov = 60.0
        self.placed: set[int] = set()
        self.runs = 0
        gui = server.gui
        gui.configure_theme(control_width="large")
        self.status = gui.add_markdown("Starting…")
        with gui.add_folder("Run"):
            self.preview_button = gui.add_button("Preview (through place_objects)")
            self.full_button = gui.add_button("Full fit")
            self.stages = gui.add_markdown("")
            self.command = gui.add_markdown("")
        with gui.add_folder("In the 3D view"):
            self.exported = gui.add_checkbox(
                "Exported scene",
                initial_value=False,
                disabled=True,
                hint="after a full fit: the glTF scene, or the objects and points",
            )
            self.plane = gui.add_checkbox(
                "Photo on its camera",
                initial_value=False,
                hint="the photo on the camera's image plane (in front of what it became)",
            )
            self.objects = gui.add_markdown("")
        with gui.add_folder("Photo"):
            self.photo = gui.add_image(
                np.zeros((8, 8, 3), np.uint8), label="segmentation and object boxes (hover: expand)"
            )
            self.overlay = gui.add_checkbox("Show segmentation", initial_value=True)
            self.show_crops = gui.add_checkbox(
                "Show crop windows",
                initial_value=False,
                hint="after a full fit: the windows material retrieval compares",
            )
        with gui.add_folder("Segments"):
            self.region = gui.add_dropdown("Segment", ["(none)"])
            self.category = gui.add_dropdown("Is a", list(CATEGORIES), initial_value="wall")
            self.mark_button = gui.add_button(
                "Mark segment", hint="writes the studio's copy of the segmentation, so marked, beside the photo"
            )
            self.reset_button = gui.add_button(
                "Reset segmentation",
                hint="deletes the studio's copy: back to your segmentation file, or the automatic one",
            )
        with gui.add_folder("Object boxes"):
            self.box = gui.add_dropdown("Box", ["(none)"])
            self.label = gui.add_dropdown(
                "Label",
                ["object", *DB_CATEGORIES],
                initial_value="object",
                hint="a database category steers retrieval to its models",
            )
            self.relabel_button = gui.add_button("Relabel box")
            self.delete_button = gui.add_button("Delete box")
            self.draw_button = gui.add_button("Draw a box", hint="then drag a rectangle over the photo in the 3D view")
        with gui.add_folder("Crop windows (after a full fit)"):
            self.crop = gui.add_dropdown("Crop", ["(none)"])
            self.move_crop_button = gui.add_button("Move crop", hint="then drag its new window over the photo")
            self.delete_crop_button = gui.add_button("Delete crop", hint="a part with no crop becomes homogeneous")
            self.crop_part = gui.add_dropdown("Crop part", ["(none)"])
            self.add_crop_button = gui.add_button("Add crop", hint="then drag a window over the part's plain surface")
        with gui.add_folder("Candidates"):
            self.segment = gui.add_dropdown("Object", ["(none)"])
            self.thumbs = gui.add_image(thumbnail_strip([], []), label="top candidates (rank: score)")
            self.scores = gui.add_markdown("")
            self.candidate = gui.add_dropdown("Candidate", ["(none)"])
            self.model_id = gui.add_text("or model id", initial_value="", hint="any id of `psdr-room-db list`")
            self.pick_button = gui.add_button("Pick")
        with gui.add_folder("Edit (after a full fit)"):
            self.part = gui.add_dropdown("Part", ["(none)"])
            self.material = gui.add_dropdown("Material", ["homogeneous", *library.names()], initial_value="homogeneous")
            self.material_look = gui.add_image(np.full((LOOK, LOOK, 3), 255, np.uint8), label="the material's look")
            self.add_material_button = gui.add_button("Add material edit")
            self.part_look = gui.add_image(np.full((LOOK, LOOK, 3), 255, np.uint8), label="the part's look, as edited")
            self.parameters = gui.add_folder("Graph parameters of the part")
            with self.parameters:
                self.parameters_note = gui.add_markdown("")
            self.light_scale = gui.add_slider("Light scale", min=0.0, max=4.0, step=0.05, initial_value=1.0)
            self.light_colour = gui.add_rgb(
                "Light colour", initial_value=(255, 255, 255), hint="a colour filter on every light (white: none)"
            )
            self.fov = gui.add_slider("FoV (degrees)", min=20.0, max=120.0, step=0.5, initial_value=60.0)
            self.edits_text = gui.add_markdown("")
            self.render_button = gui.add_button(
                "Render edit", hint="writes scene-edited/ (with render.png) in the run folder"
            )
            self.render = gui.add_image(np.zeros((8, 8, 3), np.uint8), label="edited render")
        self.material_edits: dict[str, str] = {}
        self.param_edits: dict[str, dict[str, float | list[float]]] = {}
        self.scene_parts: dict[str, dict[str, Any]] = {}
        self.param_handles: list[Any] = []

        def preview(_: Any) -> None:
            self.start_run(PREVIEW)

        def full(_: Any) -> None:
            self.start_run(None)

        self.preview_button.on_click(preview)
        self.full_button.on_click(full)
        self.overlay.on_update(lambda _: self.refresh_photo())
        self.exported.on_update(lambda _: self.view.exported(self.exported.value))
        self.plane.on_update(lambda _: self.view.photo_plane(self.plane.value))
        self.relabel_button.on_click(
            lambda _: self.act(lambda: self.session.relabel_box(self._box_index(), self.label.value))
        )
        self.delete_button.on_click(lambda _: self.act(lambda: self.session.delete_box(self._box_index())))
        self.draw_button.on_click(
            lambda event: self._draw_mode(event, lambda: "a rectangle around the object", self.add_box_from_screen)
        )
        self.show_crops.on_update(lambda _: self.refresh_photo())
        self.move_crop_button.on_click(
            lambda event: self._draw_mode(
                event,
                lambda: f"crop {self._crop_index()}'s new window",
                lambda *screen: self.session.move_crop(self._crop_index(), self.photo_box(*screen)),
            )
        )
        self.delete_crop_button.on_click(lambda _: self.act(lambda: self.session.delete_crop(self._crop_index())))
        self.add_crop_button.on_click(
            lambda event: self._draw_mode(
                event,
                lambda: f"a window over {self._crop_part()}'s plain surface",
                lambda *screen: self.session.add_crop(self._crop_part(), self.photo_box(*screen)),
            )
        )
        self.mark_button.on_click(
            lambda _: self.act(lambda: self.session.mark_segment(self._region_id(), self.category.value))
        )
        self.reset_button.on_click(lambda _: self.act(self.session.reset_segmentation))
        self.segment.on_update(lambda _: self.refresh_candidates())
        self.pick_button.on_click(lambda _: self.act(self._pick))
        self.add_material_button.on_click(lambda _: self._add_material())
        self.material.on_update(lambda _: self._show_material_look())
        self.part.on_update(lambda _: self.refresh_parameters())
        self.light_scale.on_update(lambda _: self._show_edits())
        self.light_colour.on_update(lambda _: self._show_edits())
        self.fov.on_update(lambda _: self._show_edits())
        self.render_button.on_click(lambda _: self._start_edit())
        server.on_client_connect(self._connect)

    def _connect(self, client: viser.ClientHandle) -> None:
        """A page opens out of any drawing mode a page before it left on (a reload must not take an orbit drag for a
        box), on the overview."""
        if self.drawing is not None:
            self._end_drawing()
            self.say("Drawing stopped: the page was opened again. Press the drawing button again to draw.")
        self._greet(client)

    def _greet(self, client: viser.ClientHandle) -> None:
        """A page opens on an overview of the photo's camera and the scene (once there is a run to show)."""
        if self.session.record is not None and client.client_id not in self.placed:
            self.placed.add(client.client_id)
            overview(client, self.session.record.artifacts)

    # -- messages and runs --------------------------------------------------------------------------------------

    def say(self, text: str) -> None:
        self.status.content = text

    def act(self, change: Any) -> None:
        """Apply one correction; a wrong one is reported in the page and changes nothing."""
        try:
            change()
        except PsdrRoomError as exc:
            self.say(f"**Not changed:** {plain(str(exc))}")
            return
        self.say(
            "Changed; run the preview or the full fit to see it. Files: "
            f"`{self.session.boxes_file}` (boxes), `{self.session.segmentation_file}` (the studio's copy of the "
            "segmentation: marks, and boxes where the segments come from a file), "
            f"`{self.session.crops_file}` (crop windows), "
            f"`{self.session.run_dir / 'studio.yaml'}` (picks, marks)."
        )
        self.refresh_lists()
        self.refresh_photo()

    def start_run(self, until: str | None) -> threading.Thread | None:
        """Run the pipeline through ``until`` (None: all) on a worker thread; the page follows its stages."""
        if self.session.running:
            self.say("A run is in progress; wait for it to finish.")
            return None
        worker = threading.Thread(target=self._run, args=(until,), daemon=True, name="psdr-room-studio-run")
        worker.start()
        return worker

    def _run(self, until: str | None) -> None:
        self.progress = {}
        self.runs += 1
        what = "preview" if until else "full fit"
        self.say(f"Run {self.runs} ({what}) running…")
        started = time.perf_counter()
        try:
            record = self.session.run(until, self._on_stage)
        except PsdrRoomError as exc:
            self.say(f"**Run {self.runs} failed:** {plain(str(exc))}")
            return
        cached = sum(r.cached for r in record.stages)
        self.say(
            f"Run {self.runs} ({what}) done in {time.perf_counter() - started:.1f} s: {len(record.stages)} "
            f"stages, {cached} from the cache."
        )
        self.refresh()

    def _on_stage(self, event: StageEvent) -> None:
        self.progress[event.stage] = event
        rows = [
            f"| {e.stage} | {e.state} | {e.seconds:.2f} |" if e.state != "running" else f"| {e.stage} | running… | |"
            for e in self.progress.values()
        ]
        self.stages.content = "\n".join(["| stage | | s |", "|---|---|---|", *rows])

    # -- views --------------------------------------------------------------------------------------------------

    def refresh(self) -> None:
        """Redraw everything from the latest run."""
        record = self.session.record
        if record is None:
            return
        scene_dir = self.session.run_dir / "scene" if "scene" in record.artifacts else None
        self.view.show(record.artifacts, scene_dir)
        if self.exported.disabled == (scene_dir is not None):  # a first exported scene is shown; none, nothing to tick
            self.exported.disabled = scene_dir is None
            self.exported.value = scene_dir is not None  # type: ignore[misc]  # viser 1.1: a setter apart from its getter reads as read-only
        self.view.exported(self.exported.value)
        camera = record.artifact(("camera_fit", "camera"), Camera)
        if camera is not None:
            self.fov.value = self.initial_fov = round(camera.vfov_deg * 2) / 2  # type: ignore[misc]  # viser 1.1: a setter apart from its getter reads as read-only
        for client in self.server.get_clients().values():
            self._greet(client)
        placements = record.artifact(("placements_fit", "placements"), Placements)
        self.objects.content = "\n".join(
            [
                "| segment | label | model |",
                "|---|---|---|",
                *(f"| {p.segment_id} | {p.label} | {p.model_id} |" for p in (placements.objects if placements else [])),
            ]
        )
        self.command.content = f"Reproduce with:\n\n```\n{self.session.command()}\n```"
        self.refresh_lists()
        self.refresh_photo()
        self.refresh_edit()

    def refresh_edit(self) -> None:
        """The parts and field of view of the exported scene (after a full fit); the edits start over."""
        scene = self.session.run_dir / "scene" / "appearance.json"
        record = self.session.record
        if record is None or "scene" not in record.artifacts or not scene.is_file():
            return
        state = load_state(scene.parent, self.library)
        self.scene_parts = {p["part"]: p for p in state["parts"]}
        self.part.options = list(self.scene_parts)
        self.material_edits = {}
        self.param_edits = {}
        self.light_scale.value = 1.0  # type: ignore[misc]  # viser 1.1: a setter apart from its getter reads as read-only
        self.light_colour.value = (255, 255, 255)  # type: ignore[misc]  # viser 1.1: a setter apart from its getter reads as read-only
        self._show_edits()
        self._show_material_look()
        self.refresh_parameters()

    def edits(self) -> list[str]:
        """The ``psdr-room-edit`` edits the Edit controls describe."""
        out = [f"material.{part}={name}" for part, name in self.material_edits.items()]
        out += [
            f"material.{part}.{key}={json.dumps(value, separators=(',', ':'))}"
            for part, values in self.param_edits.items()
            for key, value in values.items()
        ]
        colour = srgb_to_linear(np.asarray(self.light_colour.value, np.float64) / 255.0)
        light = [round(float(self.light_scale.value) * float(c), 4) for c in colour]
        if any(abs(c - 1.0) > 1e-9 for c in light):
            out.append(
                f"light.scale={light[0]:g}"
                if len(set(light)) == 1
                else f"light.scale={json.dumps(light, separators=(',', ':'))}"
            )
        if abs(float(self.fov.value) - self.initial_fov) > 1e-9:
            out.append(f"camera.fov={float(self.fov.value):g}")
        return out

    def _show_edits(self) -> None:
        scene = self.session.run_dir / "scene"
        self.edits_text.content = (
            f"```\npsdr-room-edit {scene} {' '.join(self.edits())} --out {self.session.run_dir / EDITED}\n```"
        )

    def _add_material(self) -> None:
        if self.part.value == "(none)":
            self.say("**Not changed:** no exported scene yet; run the full fit first")
            return
        self.material_edits[self.part.value] = self.material.value
        self.param_edits.pop(self.part.value, None)
        self._show_edits()
        self.refresh_parameters()

    # -- a part's material and its graph parameters -------------------------------------------------------------

    def part_material(self, part: str) -> tuple[str | None, dict[str, Any]]:
        """The library material ``part`` wears with the edits so far (None: homogeneous) and the values of its
        continuous graph parameters (``node.param`` → value)."""
        if part in self.material_edits:
            name: str | None = None if self.material_edits[part] == "homogeneous" else self.material_edits[part]
            exported: dict[str, Any] = {}
        else:
            state = self.scene_parts.get(part, {})
            name = state.get("material") if state.get("kind") == "procedural" else None
            exported = dict(state.get("params", {}))
        if name is None:
            return None, {}
        values = {key: b.value.tolist() for key, b in self.library.material(name).bounds.items()}
        return name, {**values, **exported, **self.param_edits.get(part, {})}

    def refresh_parameters(self) -> None:
        """One slider per scalar graph parameter of the chosen part (three for a colour or vector), within its
        range; a change becomes a ``material.<part>.<node.param>=`` edit."""
        for handle in self.param_handles:
            handle.remove()
        self.param_handles = []
        part = str(self.part.value)
        name, values = self.part_material(part)
        if name is None:
            self.parameters_note.content = "homogeneous: no graph parameters" if part in self.scene_parts else ""
            self._show_part_look()
            return
        gui, others = self.server.gui, []
        with self.parameters:
            for key, bound in self.library.material(name).bounds.items():
                value, lo, hi = (np.asarray(v, np.float64) for v in (values[key], bound.lo, bound.hi))
                if value.size == 1:
                    handle = gui.add_slider(
                        key,
                        min=float(lo),
                        max=float(hi),
                        step=slider_step(float(lo), float(hi)),
                        initial_value=float(value),
                    )
                elif value.shape == (3,):
                    lo, hi = np.broadcast_to(lo, (3,)), np.broadcast_to(hi, (3,))
                    handle = gui.add_vector3(
                        key,
                        tuple(value),
                        min=tuple(lo),
                        max=tuple(hi),
                        step=slider_step(float(lo.min()), float(hi.max())),
                    )
                else:
                    others.append(key)
                    continue
                handle.on_update(
                    lambda _, part=part, key=key, handle=handle: self._set_parameter(part, key, handle.value)
                )
                self.param_handles.append(handle)
        self.parameters_note.content = f"**{plain(name)}**" + (
            f"; edit {', '.join(plain(k) for k in others)} with `psdr-room-edit material.{part}.<param>=...`"
            if others
            else ""
        )
        self._show_part_look()

    def _set_parameter(self, part: str, key: str, value: Any) -> None:
        self.param_edits.setdefault(part, {})[key] = (
            [round(float(v), 6) for v in value]
            if isinstance(value, (list, tuple, np.ndarray))
            else round(float(value), 6)
        )
        self._show_edits()
        self._show_part_look()

    def _show_material_look(self) -> None:
        """The look of the material chosen in *Material* (what *Add material edit* would put on the part)."""
        name = str(self.material.value)
        if name == "homogeneous":
            self.material_look.image = np.full((LOOK, LOOK, 3), 255, np.uint8)
            return
        self.material_look.image = tensor_to_uint8(self.library.appearance(name, LOOK))

    def _show_part_look(self) -> None:
        """The chosen part's material at its edited values (a homogeneous part: its flat colour)."""
        part = str(self.part.value)
        name, values = self.part_material(part)
        if name is not None:
            self.part_look.image = tensor_to_uint8(self.library.appearance(name, LOOK, values))
        elif part in self.scene_parts:
            colour = linear_to_srgb(torch.tensor(self.scene_parts[part]["base_color"], dtype=torch.float32))
            self.part_look.image = np.broadcast_to(
                np.round(colour.numpy() * 255).astype(np.uint8), (LOOK, LOOK, 3)
            ).copy()

    def _start_edit(self) -> None:
        threading.Thread(target=self._edit, daemon=True, name="psdr-room-studio-edit").start()

    def _edit(self) -> None:
        edits = self.edits()
        self.say("Rendering the edit…")
        try:
            out = self.session.edit(edits)
        except PsdrRoomError as exc:
            self.say(f"**Not changed:** {plain(str(exc))}")
            return
        render = cv2.imread(str(out / "render.png"))
        if render is None:
            self.say(f"**Not shown:** {out / 'render.png'} could not be read")
            return
        self.render.image = cv2.cvtColor(render, cv2.COLOR_BGR2RGB)
        self.view.show_scene(out / "scene.glb")
        self.say(
            f"Edited ({len(edits)} edit{'' if len(edits) == 1 else 's'}): `{out}` (render.png, scene.glb, scene.xml)."
        )

    def refresh_lists(self) -> None:
        try:
            boxes = self.session.boxes()
        except PsdrRoomError:
            boxes = []
        self.box.options = [f"{i}: {b.label}" for i, b in enumerate(boxes)] or ["(none)"]
        panoptic = self.session.artifact("panoptic", Panoptic)
        self.region.options = [
            f"{s.id}: {s.label} ({s.category})" for s in (panoptic.segments if panoptic is not None else [])
        ] or ["(none)"]
        candidates = self.session.artifact("object_candidates", ObjectCandidates)
        segments = sorted(candidates.ranked) if candidates is not None else []
        labels = candidates.labels if candidates is not None else {}
        self.segment.options = [f"{s}: {labels.get(s, '')}" for s in segments] or ["(none)"]
        self.crop.options = [f"{i}: {c.get('part', 'render window')}" for i, c in enumerate(self._crops())] or [
            "(none)"
        ]
        self.crop_part.options = self.session.crop_parts() or ["(none)"]
        self.refresh_candidates()

    def _crops(self) -> list[dict[str, Any]]:
        try:
            return self.session.crops()
        except PsdrRoomError:
            return []

    def refresh_photo(self) -> None:
        """The photo panel: the photo at :data:`PHOTO_WIDTH` with the segmentation, the object boxes, the GrabCut mask
        of a box just drawn and (asked for) the crop windows, captioned legibly at the panel's width."""
        image = self.session.artifact("image", Image)
        if image is None:
            return
        photo = image.to_uint8()
        zoom = PHOTO_WIDTH / photo.shape[1]
        size = (PHOTO_WIDTH, round(photo.shape[0] * zoom))
        photo = cv2.resize(photo, size, interpolation=cv2.INTER_LINEAR)
        panoptic = self.session.artifact("panoptic", Panoptic)
        if self.overlay.value and panoptic is not None:
            ids = cv2.resize(panoptic.ids, size, interpolation=cv2.INTER_NEAREST)
            photo = segment_overlay(photo, Panoptic(ids=ids, segments=panoptic.segments), text_scale=PHOTO_TEXT * 0.9)
        if self.mask is not None and self.mask.shape == (image.height, image.width):
            mask = cv2.resize(self.mask.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0
            photo[mask] = (0.5 * photo[mask] + (0, 110, 0)).astype(np.uint8)
        sx, sy = photo_scale(image)
        sx, sy = sx * zoom, sy * zoom
        try:
            boxes = self.session.boxes()
        except PsdrRoomError:
            boxes = []
        photo = draw_boxes(
            photo, [(f"{i}: {b.label}", scaled(b.box, sx, sy)) for i, b in enumerate(boxes)], text_scale=PHOTO_TEXT
        )
        if self.show_crops.value:
            photo = draw_boxes(
                photo,
                [
                    (f"crop {i}: {c.get('part', 'render window')}", scaled(c["image"], sx, sy))
                    for i, c in enumerate(self._crops())
                ],
                colour=(0, 220, 255),
                text_scale=PHOTO_TEXT,
            )
        self.photo.image = photo

    def refresh_candidates(self) -> None:
        candidates = self.session.artifact("object_candidates", ObjectCandidates)
        segment = self._segment_id()
        if candidates is None or segment is None:
            self.candidate.options = ["(none)"]
            return
        ranked = candidates.ranked[segment]
        chosen = self.session.picks.get(segment)
        self.candidate.options = [
            f"{rank}: {c.model_id} ({c.score:.3f})" + (" ← picked" if chosen == rank else "")
            for rank, c in enumerate(ranked)
        ]
        images = [self.database.thumbnails(c.model_id, views=[0])[0] for c in ranked]
        self.thumbs.image = thumbnail_strip(images, [f"{rank}: {c.score:.2f}" for rank, c in enumerate(ranked)])
        self.scores.content = score_table(ranked)

    # -- corrections --------------------------------------------------------------------------------------------

    @staticmethod
    def _chosen(dropdown: Any, missing: str) -> int:
        """The number an ``N: …`` option of ``dropdown`` starts with; ``missing`` when none is chosen."""
        head = str(dropdown.value).split(":")[0]
        if not head.isdigit():
            raise PsdrRoomError(missing)
        return int(head)

    def _box_index(self) -> int:
        return self._chosen(self.box, "no box to change; draw one first")

    def _region_id(self) -> int:
        return self._chosen(self.region, "no segment to mark; run the preview first")

    def _segment_id(self) -> int | None:
        head = self.segment.value.split(":")[0]
        return int(head) if head.isdigit() else None

    def _pick(self) -> None:
        segment = self._segment_id()
        if segment is None:
            raise PsdrRoomError("no object with candidates; run the preview first")
        typed = self.model_id.value.strip()
        rank = self.candidate.value.split(":")[0]
        if not typed and not rank.isdigit():
            raise PsdrRoomError("no candidate chosen; choose one or type a model id")
        choice: int | str = typed if typed else int(rank)
        self.session.pick(segment, choice, self.database)

    def _crop_index(self) -> int:
        return self._chosen(self.crop, "no crop window to change; run the full fit first")

    def _crop_part(self) -> str:
        if self.crop_part.value == "(none)":
            raise PsdrRoomError("no scene part to crop; run the full fit first")
        return str(self.crop_part.value)

    def _draw_mode(
        self,
        event: viser.GuiEvent,
        what: Callable[[], str],
        take: Callable[[Any, tuple[float, float], tuple[float, float]], None],
    ) -> None:
        """Put the browser's view at the photo's camera and give the next rectangle dragged on the canvas to ``take``
        (the browser's camera and the rectangle's screen corners); ``what`` names what to drag (or refuses)."""
        if event.client is None or self.session.record is None:
            self.say("Run the preview first.")
            return
        try:
            target = what()
        except PsdrRoomError as exc:
            self.say(f"**Not changed:** {plain(str(exc))}")
            return
        self._end_drawing()
        self.view.photo_view(event.client, self.session.record.artifacts)
        self.view.photo_plane(True)  # the rectangle is drawn over the photo

        @self.server.scene.on_rect_select()
        def _(selection: Any) -> None:
            self._end_drawing()
            self.act(lambda: take(selection.client.camera, selection.screen_min, selection.screen_max))

        self.drawing = _

        # Said last: the browser takes messages in order, so once this shows, the view and the selection are ready.
        self.say(f"Drag {target} on the photo (the view is at the photo's camera).")

    def _end_drawing(self) -> None:
        """Leave the drawing mode, if on: the canvas orbits again and the photo plane is as ticked."""
        if self.drawing is not None:
            self.server.scene.remove_rect_select_callback(self.drawing)
            self.drawing = None
        self.view.photo_plane(self.plane.value)

    def photo_box(self, client_camera: Any, screen_min: tuple[float, float], screen_max: tuple[float, float]) -> Box:
        """The box (photo pixels) a rectangle on the canvas covers on the photo, clipped to it."""
        working = self._working_box(client_camera, screen_min, screen_max)
        sx, sy = photo_scale(self.session.run_image())
        return scaled(working, 1 / sx, 1 / sy)

    def _working_box(self, client_camera: Any, screen_min: tuple[float, float], screen_max: tuple[float, float]) -> Box:
        artifacts = self.session.record.artifacts if self.session.record is not None else {}
        image = first_artifact(artifacts, "image", Image)
        camera = first_artifact(artifacts, ("camera_fit", "camera"), Camera)
        room = first_artifact(artifacts, ("room_box_objects", "room_box_fit", "room_box"), RoomBox)
        if image is None or camera is None or room is None:
            raise PsdrRoomError("run the preview first: a rectangle is drawn on the photo's camera")
        corners = [
            screen_to_photo(client_camera, corner, camera, room.camera_to_world) for corner in (screen_min, screen_max)
        ]
        if any(c is None for c in corners):
            raise PsdrRoomError("the rectangle is not on the photo; press the button again and drag over the photo")
        (x0, y0), (x1, y1) = corners  # type: ignore[misc]
        x0, x1 = sorted((max(0.0, x0), min(float(image.width), x1)))
        y0, y1 = sorted((max(0.0, y0), min(float(image.height), y1)))
        if x1 - x0 < 4 or y1 - y0 < 4:
            raise PsdrRoomError("the rectangle covers less than 4 pixels of the photo; drag a larger one")
        return x0, y0, x1, y1

    def add_box_from_screen(
        self, client_camera: Any, screen_min: tuple[float, float], screen_max: tuple[float, float]
    ) -> None:
        """Add the box a rectangle on the canvas covers on the photo, and show its GrabCut mask."""
        working = self._working_box(client_camera, screen_min, screen_max)
        image = self.session.run_image()
        self.mask = grabcut_mask(image.to_uint8(), working, self.session.grabcut())
        sx, sy = photo_scale(image)
        self.session.add_box(scaled(working, 1 / sx, 1 / sy), label=self.label.value, mask=self.mask)
