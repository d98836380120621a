"""One studio session: a photo, the user's corrections as the CLI's own files, and runs of the CLI's pipeline.

Corrections are written where ``psdr-room`` reads them, so the plain command reproduces the studio's scene:

- object boxes (added, deleted, relabelled) → ``<photo stem>.boxes.yaml`` beside the photo (``detector=auto``
  takes it over the detector), or, where the segments come from a file (the user's LabelMe or panoptic sidecar),
  the studio's copy of that segmentation with the box's GrabCut mask added, the object's segment removed or
  relabelled (``<photo stem>.studio.panoptic.png`` + ``.json``, which ``segmentation=file`` prefers; the user's
  file is never written);
- candidate picks → ``+place_objects.pick.<segment>=<rank or model id>`` overrides, kept in the run folder's
  ``studio.yaml`` and shown as the command line that reproduces the run;
- segments marked as a room category (wall, floor, ceiling, window, door, lamp, object) → the studio's copy of
  the segmentation so marked (``segmentation=auto`` takes it over the offline layout method); the marks are
  listed in ``studio.yaml``;
- crop windows (moved, added, deleted) → ``<photo stem>.crops.yaml`` beside the photo (``assign_materials`` takes
  it in place of its own crops).

Runs go through :func:`~psdr_room_core.engine.run.execute` on a config from
:func:`~psdr_room_core.engine.cli.compose_config`, exactly as ``psdr-room`` runs; the cache makes the stages a
correction does not reach instant.
"""

from __future__ import annotations

import os
import tempfile
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import yaml
from omegaconf import OmegaConf

from psdr_room_core.applications.edit import edit_scene
from psdr_room_core.engine.cli import compose_config, hydra_quote
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import PluginSystem, load_plugins
from psdr_room_core.engine.records import RunRecord, StageRecord
from psdr_room_core.engine.registry import Origin
from psdr_room_core.engine.run import execute
from psdr_room_core.libraries.sidecar_segmentation import panoptic_json_for, studio_segmentation_path
from psdr_room_core.method.artifacts import (
    CATEGORIES,
    Detection,
    Detections,
    Image,
    MaterialAssignment,
    ObjectCandidates,
    Panoptic,
    Segment,
    write_coco_panoptic,
)
from psdr_room_core.method.crops import check_crops, crops_file, load_crops, write_crops
from psdr_room_plugins.detectors.boxes_file import photo_scale, read_boxes, scaled, sidecar_path, write_boxes
from psdr_room_plugins.layout.objects import grabcut_mask
from psdr_room_plugins.layout.settings import GrabCutParams
from psdr_room_plugins.segmentation_file import read_segmentation

ArtifactT = TypeVar("ArtifactT")

PREVIEW = "place_objects"
"""The last stage of a preview run (the first posed scene)."""
STATE_FILE = "studio.yaml"
EDITED = "scene-edited"
"""The run folder's edited copy of its exported ``scene/`` (``psdr-room-edit``'s ``--out``)."""


def _objects(panoptic: Panoptic) -> list[Segment]:
    """The object segments, in id order (the order of :meth:`Session.boxes` where segments come from a file)."""
    return sorted((s for s in panoptic.segments if s.category == "object"), key=lambda s: s.id)


def _segment_box(ids: np.ndarray, segment_id: int) -> tuple[float, float, float, float]:
    """The box (pixel edges, ``x1``/``y1`` exclusive) of a segment's pixels."""
    ys, xs = np.nonzero(ids == segment_id)
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


@dataclass(frozen=True)
class StageEvent:
    """A stage starting (``running``) or ending (``cached``, ``computed``, ``failed``), as the run-event hooks say."""

    stage: str
    state: str
    seconds: float = 0.0


class StageEvents:
    """Run-event hooks (the console plugin's) that forward stage progress to the session's listener."""

    def __init__(self) -> None:
        self.listener: Callable[[StageEvent], None] = lambda event: None

    @hookimpl
    def before_stage(self, record: StageRecord, inputs: dict[str, Any]) -> None:
        self.listener(StageEvent(record.name, "running"))

    @hookimpl
    def after_stage(self, record: StageRecord, outputs: dict[str, Any]) -> None:
        self.listener(StageEvent(record.name, "cached" if record.cached else "computed", record.seconds))

    @hookimpl
    def on_stage_error(self, record: StageRecord, error: BaseException) -> None:
        self.listener(StageEvent(record.name, "failed"))


def studio_plugins() -> tuple[PluginSystem, StageEvents]:
    """Every installed plugin, as ``psdr-room`` loads them, plus the studio's stage-event listener."""
    events = StageEvents()
    return load_plugins(extra=[(events, Origin("studio", "psdr-room", "(studio)"))]), events


def _check_category(category: str) -> None:
    if category not in CATEGORIES:
        raise PsdrRoomError(f"category {category!r} is unknown; use one of {', '.join(CATEGORIES)}")


class Session:
    """The photo, its run folder, its corrections and its latest run. Methods that change a correction check it
    first and raise :class:`PsdrRoomError` with one line (changing nothing) when it is wrong."""

    def __init__(
        self, photo: Path, overrides: list[str], run_dir: Path, plugins: PluginSystem, events: StageEvents
    ) -> None:
        self.photo = photo.expanduser().absolute()
        self.overrides = list(overrides)
        self.run_dir = run_dir.expanduser().absolute()
        self.plugins = plugins
        self.events = events
        self.picks, self.marks = self._load_state()
        self.record: RunRecord | None = None
        self.detector = "auto"
        self._lock = threading.Lock()

    # -- runs ---------------------------------------------------------------------------------------------------

    def arguments(self, until: str | None = None) -> list[str]:
        """The ``psdr-room`` overrides of a run: the photo, the user's overrides, the picks, the stop stage."""
        picks = [
            f"+place_objects.pick.{segment}={choice if isinstance(choice, int) else hydra_quote(choice)}"
            for segment, choice in sorted(self.picks.items())
        ]
        return [
            f"image={hydra_quote(str(self.photo))}",
            *self.overrides,
            *picks,
            *([f"run.until={until}"] if until else []),
        ]

    def grabcut(self) -> GrabCutParams:
        """The settings of the GrabCut that cuts a drawn box's object out: ``segmentation=layout``'s, as shipped."""
        node = compose_config(["segmentation=layout"], self.plugins).segmentation.layout.grabcut
        return GrabCutParams(**OmegaConf.to_container(node, resolve=True))  # type: ignore[arg-type]

    def command(self, until: str | None = None) -> str:
        """The command line that reproduces the run (with the boxes file beside the photo)."""
        return " ".join(["psdr-room", *self.arguments(until), f"hydra.run.dir={hydra_quote(str(self.run_dir))}"])

    def run(self, until: str | None = None, listener: Callable[[StageEvent], None] | None = None) -> RunRecord:
        """Run the pipeline through ``until`` (None: all of it) into the run folder; one run at a time."""
        if not self._lock.acquire(blocking=False):
            raise PsdrRoomError("a run is in progress; wait for it to finish")
        try:
            self.events.listener = listener or (lambda event: None)
            cfg = compose_config(self.arguments(until), self.plugins)
            self.detector = str(cfg.detector.impl)
            self.record = execute(cfg, self.run_dir, self.plugins)
            return self.record
        finally:
            self.events.listener = lambda event: None
            self._lock.release()

    def edit(self, edits: list[str], spp: int = 32) -> Path:
        """Apply ``psdr-room-edit`` edits (``KEY=VALUE``) to the run's exported scene and render it: the run
        folder's ``scene-edited/`` (a whole scene folder, with ``render.png``)."""
        scene = self.run_dir / "scene"
        if not (scene / "appearance.json").is_file():
            raise PsdrRoomError("no exported scene yet: run the full fit first")
        if not self._lock.acquire(blocking=False):
            raise PsdrRoomError("a run is in progress; wait for it to finish")
        try:
            return edit_scene(scene, edits, self.run_dir / EDITED, spp)
        finally:
            self._lock.release()

    @property
    def running(self) -> bool:
        return self._lock.locked()

    def artifact(self, name: str, kind: type[ArtifactT]) -> ArtifactT | None:
        """Artifact ``name`` of the latest run when it is a ``kind``, or None."""
        return self.record.artifact(name, kind) if self.record is not None else None

    # -- object boxes -------------------------------------------------------------------------------------------

    @property
    def boxes_file(self) -> Path:
        return sidecar_path(self.photo)

    def run_image(self) -> Image:
        """The latest run's image (the photo at working size), or a one-line error before the first run."""
        image = self.artifact("image", Image)
        if image is None:
            raise PsdrRoomError("no run yet: run the preview first, then correct its boxes")
        return image

    def boxes(self) -> list[Detection]:
        """The object boxes in photo pixels: where the segments come from a file (:meth:`from_file`), the boxes of
        its object segments (in id order); else the boxes file's, else the latest run's detections."""
        image = self.run_image()
        sx, sy = photo_scale(image)
        if self.from_file():
            panoptic = self._editable()
            return [
                Detection(
                    label=s.label, category=s.category, box=scaled(_segment_box(panoptic.ids, s.id), 1 / sx, 1 / sy)
                )
                for s in _objects(panoptic)
            ]
        if self.boxes_file.is_file():
            return read_boxes(self.boxes_file, image.photo_size)
        detections = self.artifact("detections", Detections)
        return [
            Detection(label=d.label, category=d.category, box=scaled(d.box, 1 / sx, 1 / sy))
            for d in (detections.items if detections is not None else [])
        ]

    def _write_boxes(self, boxes: list[Detection]) -> None:
        """Check ``boxes`` as ``detector=boxes_file`` will read them, then write the boxes file (picks are keyed
        by segment, which new boxes renumber: they are dropped)."""
        if self.detector not in ("auto", "boxes_file"):
            raise PsdrRoomError(
                f"detector={self.detector} ignores the boxes file {self.boxes_file}; restart the "
                "studio without detector= (auto takes the boxes file)"
            )
        write_boxes(self.boxes_file, boxes, self.run_image().photo_size)
        self._drop_object_crops("object_")
        self._save_state({}, self.marks)

    def add_box(
        self,
        box: tuple[float, float, float, float],
        label: str = "object",
        category: str = "object",
        mask: np.ndarray | None = None,
    ) -> None:
        """Add an object box (photo pixels ``x0, y0, x1, y1``): to the boxes file, or, where the segments come
        from a file, as a new object segment of the studio's copy, ``mask`` (working pixels; default: the box's
        GrabCut cut) over what was there."""
        x0, y0, x1, y1 = (float(v) for v in box)
        _check_category(category)
        if not (x1 > x0 and y1 > y0):
            raise PsdrRoomError(
                f"box {[x0, y0, x1, y1]} is inverted or empty; give [x0, y0, x1, y1] with x1 > x0 and "
                "y1 > y0 (drag from one corner to the opposite one)"
            )
        if not self.from_file():
            self._write_boxes([*self.boxes(), Detection(label=label, category=category, box=(x0, y0, x1, y1))])
            return
        image = self.run_image()
        width, height = image.photo_size
        if x0 < 0 or y0 < 0 or x1 > width or y1 > height:
            raise PsdrRoomError(f"box {[x0, y0, x1, y1]} is outside the {width}x{height} photo; drag it over the photo")
        sx, sy = photo_scale(image)
        working = scaled((x0, y0, x1, y1), sx, sy)
        if mask is None:
            mask = grabcut_mask(image.to_uint8(), working, self.grabcut())
        if mask is None or not mask.any():
            raise PsdrRoomError(
                f"the box {[round(v) for v in (x0, y0, x1, y1)]} holds no object GrabCut can cut "
                "out; drag a box that fits the object more closely"
            )
        panoptic = self._editable()
        ids = panoptic.ids.copy()
        new = int(ids.max(initial=0)) + 1
        ids[mask] = new
        segment = Segment(new, category, label, box=working)  # a person drew it: kept whatever the fit (score None)
        self._write_segmentation(ids, [*panoptic.segments, segment], self.marks)

    def delete_box(self, index: int) -> None:
        """Remove box ``index`` (0-based, in :meth:`boxes` order); where the segments come from a file, its object
        segment becomes unlabelled in the studio's copy."""
        boxes = self.boxes()
        self._check_index(index, boxes)
        if not self.from_file():
            self._write_boxes(boxes[:index] + boxes[index + 1 :])
            return
        panoptic = self._editable()
        gone = _objects(panoptic)[index].id
        self._write_segmentation(
            np.where(panoptic.ids == gone, 0, panoptic.ids), [s for s in panoptic.segments if s.id != gone], self.marks
        )

    def relabel_box(self, index: int, label: str) -> None:
        """Name box ``index``'s object (a database category such as ``sofa`` steers retrieval to it; where the
        segments come from a file, the name is the segment's second opinion too: never second-guessed)."""
        boxes = self.boxes()
        self._check_index(index, boxes)
        if not label.strip():
            raise PsdrRoomError("the label is empty; give the object's name (e.g. sofa)")
        if not self.from_file():
            old = boxes[index]
            boxes[index] = Detection(label=label.strip(), category=old.category, box=old.box)
            self._write_boxes(boxes)
            return
        panoptic = self._editable()
        named = _objects(panoptic)[index].id
        self._write_segmentation(
            panoptic.ids,
            [
                replace(s, label=label.strip(), second_opinion=label.strip()) if s.id == named else s
                for s in panoptic.segments
            ],
            self.marks,
        )

    @staticmethod
    def _check_index(index: int, boxes: list[Detection]) -> None:
        if not boxes:
            raise PsdrRoomError("there are no boxes; draw one first")
        if not 0 <= index < len(boxes):
            raise PsdrRoomError(f"no box {index}; there are {len(boxes)} (0 to {len(boxes) - 1})")

    # -- candidate picks ----------------------------------------------------------------------------------------

    def pick(self, segment_id: int, choice: int | str, database: Any) -> None:
        """Place ``choice`` (a candidate rank, 0 = best, or any model id of ``database``) for object segment
        ``segment_id`` at the next run."""
        candidates = self.artifact("object_candidates", ObjectCandidates)
        if candidates is None or segment_id not in candidates.ranked:
            known = sorted(candidates.ranked) if candidates is not None else []
            raise PsdrRoomError(f"no object segment {segment_id}; segments with candidates: {known}")
        if isinstance(choice, int) or str(choice).isdigit():
            rank = int(choice)
            if not 0 <= rank < len(candidates.ranked[segment_id]):
                raise PsdrRoomError(
                    f"rank {rank} is out of range; segment {segment_id} has "
                    f"{len(candidates.ranked[segment_id])} candidates"
                )
            choice = rank
        else:
            database.record(str(choice))  # one line naming similar ids when it is unknown
        self._drop_object_crops(f"object_{segment_id}_")
        self._save_state({**self.picks, segment_id: choice}, self.marks)

    # -- the segmentation --------------------------------------------------------------------------------------

    @property
    def segmentation_file(self) -> Path:
        """The studio's own copy of the segmentation, where boxes (segments from a file) and marks go:
        ``<photo stem>.studio.panoptic.png`` (and its ``.json``); the user's files beside the photo stay as they are."""
        return studio_segmentation_path(self.photo)

    def _segmentation(self) -> str:
        """The segmentation implementation the latest run used (``auto`` resolved)."""
        used = self.record.implementations.get("segmentation", {}) if self.record is not None else {}
        return str(used.get("name", ""))

    def from_file(self) -> bool:
        """Whether the segments come from a file (the user's or the studio's copy): boxes then change the studio's
        copy of it, since the detector's boxes no longer reach the segments."""
        return self._segmentation() == "file" or self.segmentation_file.is_file()

    def _editable(self) -> Panoptic:
        """The segmentation a box or mark changes: the studio's copy when there is one, else the latest run's."""
        panoptic = self.artifact("panoptic", Panoptic)
        if panoptic is None:
            raise PsdrRoomError("no run yet: run the preview first, then correct its segments")
        if not self.segmentation_file.is_file():
            return panoptic
        return read_segmentation("coco_panoptic", self.segmentation_file, self.run_image())

    def _write_segmentation(self, ids: np.ndarray, segments: list[Segment], marks: dict[int, str]) -> None:
        """Write the studio's copy of the segmentation (whole files only; segments left with no pixels dropped)
        and keep ``marks``; picks are keyed by object, which a changed segmentation may renumber: dropped."""
        present = set(np.unique(ids).tolist())
        png, meta = self.segmentation_file, panoptic_json_for(self.segmentation_file)
        with tempfile.TemporaryDirectory(dir=self.photo.parent, prefix=".studio-") as scratch:  # whole files only
            write_coco_panoptic(
                Path(scratch) / png.name, Path(scratch) / meta.name, ids, [s for s in segments if s.id in present]
            )
            os.replace(Path(scratch) / meta.name, meta)
            os.replace(Path(scratch) / png.name, png)
        self._drop_object_crops("object_")
        self._save_state({}, marks)

    def mark_segment(self, segment_id: int, category: str) -> None:
        """Say what segment ``segment_id`` is (a room category), in the studio's copy of the segmentation, where the
        next run reads it."""
        panoptic = self._editable()
        _check_category(category)
        known = sorted(s.id for s in panoptic.segments)
        if segment_id not in known:
            raise PsdrRoomError(f"no segment {segment_id}; the segments are {known}")
        if self._segmentation() not in ("layout", "layout_eyes", "file"):  # auto's choices after file
            raise PsdrRoomError(
                f"segmentation={self._segmentation()} ignores a segmentation file beside the photo; "
                "restart the studio with segmentation=file to use the marks"
            )
        segments = [
            replace(s, category=category, label=category if category != "object" else s.label)
            if s.id == segment_id
            else s
            for s in panoptic.segments
        ]
        self._write_segmentation(panoptic.ids, segments, {**self.marks, segment_id: category})

    def reset_segmentation(self) -> None:
        """Delete the studio's copy of the segmentation (its boxes and marks): the next run reads the user's file,
        or segments the photo itself, again."""
        if not self.segmentation_file.is_file():
            raise PsdrRoomError("the studio has not changed the segmentation; nothing to reset")
        for path in (self.segmentation_file, panoptic_json_for(self.segmentation_file)):
            path.unlink(missing_ok=True)
        self._save_state({}, {})

    # -- crop windows -------------------------------------------------------------------------------------------

    @property
    def crops_file(self) -> Path:
        return crops_file(self.photo)

    def crops(self) -> list[dict[str, Any]]:
        """The crop windows as crops-file entries in photo pixels (``{image, part}`` or ``{image, render}``): the
        crops file's, else the latest full run's automatic ones."""
        image = self.run_image()
        if self.crops_file.is_file():
            data = load_crops(self.crops_file)
            check_crops(self.crops_file, data, image.photo_size, image.photo_size)  # one line when the file is wrong
            assert isinstance(data, dict), "check_crops refuses anything else"
            return list(data["crops"])
        materials = self.artifact("materials", MaterialAssignment)
        sx, sy = photo_scale(image)
        return [
            {"image": [round(v, 1) for v in scaled(rect, 1 / sx, 1 / sy)], "part": p.part}
            for p in (materials.parts if materials is not None else [])
            for rect in p.crops
        ]

    def crop_parts(self) -> list[str]:
        """The scene parts a crop can show (those of the latest full run's material assignment)."""
        materials = self.artifact("materials", MaterialAssignment)
        return [p.part for p in materials.parts] if materials is not None else []

    def _write_crops(self, entries: list[dict[str, Any]]) -> None:
        parts = self.crop_parts()
        unknown = sorted({str(e["part"]) for e in entries if "part" in e} - set(parts))
        if unknown:
            raise PsdrRoomError(f"part {unknown[0]} is not in the scene; parts: {', '.join(parts)}")
        write_crops(self.crops_file, entries, self.run_image().photo_size)

    def _drop_object_crops(self, prefix: str) -> None:
        """Remove the crops file's entries of parts named ``prefix…``: new boxes renumber the objects and a new
        model has other parts, so their crops would name parts the next run does not have."""
        if not self.crops_file.is_file():
            return
        entries = self.crops()
        kept = [e for e in entries if not str(e.get("part", "")).startswith(prefix)]
        if len(kept) < len(entries):
            write_crops(self.crops_file, kept, self.run_image().photo_size)

    def _full_fit_crops(self) -> list[dict[str, Any]]:
        if self.artifact("materials", MaterialAssignment) is None:
            raise PsdrRoomError("no crops yet: run the full fit first, then move its crop windows")
        return self.crops()

    def move_crop(self, index: int, box: tuple[float, float, float, float]) -> None:
        """Move crop ``index`` (in :meth:`crops` order) to the window ``box`` (photo pixels ``x0, y0, x1, y1``)."""
        entries = self._full_fit_crops()
        self._check_crop(index, entries)
        entries[index] = {**entries[index], "image": [round(float(v), 1) for v in box]}
        self._write_crops(entries)

    def add_crop(self, part: str, box: tuple[float, float, float, float]) -> None:
        """Add a crop window ``box`` (photo pixels) showing scene part ``part``."""
        entries = self._full_fit_crops()
        self._write_crops([*entries, {"image": [round(float(v), 1) for v in box], "part": part}])

    def delete_crop(self, index: int) -> None:
        """Remove crop ``index``; a part left with no crop becomes homogeneous (its clean pixels' median colour)."""
        entries = self._full_fit_crops()
        self._check_crop(index, entries)
        self._write_crops(entries[:index] + entries[index + 1 :])

    @staticmethod
    def _check_crop(index: int, entries: list[dict[str, Any]]) -> None:
        if not entries:
            raise PsdrRoomError("there are no crops; add one first")
        if not 0 <= index < len(entries):
            raise PsdrRoomError(f"no crop {index}; there are {len(entries)} (0 to {len(entries) - 1})")

    # -- the state file -----------------------------------------------------------------------------------------

    def _load_state(self) -> tuple[dict[int, int | str], dict[int, str]]:
        path = self.run_dir / STATE_FILE
        if not path.is_file():
            return {}, {}
        data = yaml.safe_load(path.read_text()) or {}
        picks = data.get("picks") if isinstance(data, dict) else None
        marks = data.get("marks", {}) if isinstance(data, dict) else None
        if not isinstance(picks, dict) or not isinstance(marks, dict):
            raise PsdrRoomError(
                f"{path}: expected 'picks: {{segment: rank or model id}}' and 'marks: {{segment: "
                "category}'; delete the file to start over"
            )
        return {int(k): v for k, v in picks.items()}, {int(k): str(v) for k, v in marks.items()}

    def _save_state(self, picks: dict[int, int | str], marks: dict[int, str]) -> None:
        """Keep ``picks`` and ``marks`` and write them, with the command line that reproduces the run, to
        ``studio.yaml``."""
        self.picks, self.marks = picks, marks
        write_whole(
            self.run_dir / STATE_FILE,
            yaml.safe_dump({"picks": picks, "marks": marks, "command": self.command()}, sort_keys=False),
        )
