"""``psdr-room-summary RUN_DIR...``: one table over many runs (a sweep's job folders, or any run folders).

Each run folder (one holding ``run.json`` or ``psdr-room.log``; a folder holding neither is searched for them, so a
``--multirun`` sweep folder names all its jobs) becomes a row: photo, status (``ok``, or ``failed`` with the log's
last error, or with what is wrong in a damaged ``run.json`` or ``metrics.json``), the implementations chosen, FoV,
fitted objects, RMSE / SSIM / ꟻLIP at init → after the fit, and what the run cost: per stage the seconds it
computed, or ``cached`` (0 s: the stage's result came from the cache, whatever it cost the run that made it), their
sum, and the run's wall seconds. Written as ``summary.csv`` and a self-contained ``summary.html`` (a table that
fits a laptop screen: each run's stages on a detail row below it) with each photo | render thumbnail, linked to the
run's ``report.html``. Every ``psdr-room --multirun`` sweep writes them into its sweep folder too
(:class:`SweepSummary`, a Hydra callback).
"""

from __future__ import annotations

import argparse
import base64
import csv
import html
import io
import json
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml
from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from psdr_room_core.engine.errors import PsdrRoomError

MARKERS = ("run.json", "psdr-room.log")
"""Files that make a folder a run folder (``run.json``: published; the log alone: the run failed)."""
THUMB_HEIGHT = 96
PAGE_COLUMNS = (
    ("photo | render", "270px"),
    ("photo and run", "13%"),
    ("status", "17%"),
    ("FoV °", "4%"),
    ("objects", "5%"),
    ("RMSE", "9.5%"),
    ("SSIM", "9.5%"),
    ("ꟻLIP", "9.5%"),
    ("computed s", "6%"),
    ("wall s", "5.5%"),
)
"""The page's columns and their widths (a fixed layout: the table never grows past the window, cells wrap)."""


def find_runs(paths: Iterable[Path]) -> list[Path]:
    """The run folders given or found under the given folders (sorted within each), each once."""
    runs: list[Path] = []
    for path in paths:
        if not path.is_dir():
            raise PsdrRoomError(f"{path}: not a folder; give run folders or a sweep folder (hydra.sweep.dir)")
        found = (
            [path]
            if any((path / m).is_file() for m in MARKERS)
            else sorted({f.parent for m in MARKERS for f in path.rglob(m) if ".publishing-" not in str(f)})
        )
        if not found:
            raise PsdrRoomError(f"{path}: no run folder in it (none holds run.json or psdr-room.log)")
        runs += [r for r in found if r not in runs]
    return runs


FIT_KEYS = ("rmse_init", "rmse", "ssim_init", "ssim", "flip_init", "flip")
"""The appearance fit's figures a row shows (``fit_appearance_log`` in ``metrics.json``)."""
NUMBER, OBJECT, STRING, BOOLEAN, NULL = "a number", "an object", "a string", "true or false", "null"
"""JSON kinds, as a damaged file's reason names them."""


class DamagedRun(Exception):
    """A run's file that is not as psdr-room writes it: the message (the file, the key, what is wrong) is the reason
    on the run's failed row."""


def _read(file: Path) -> bytes:
    try:
        return file.read_bytes()
    except OSError as error:
        raise DamagedRun(f"{file}: unreadable ({error.strerror})") from None


def _json_object(file: Path) -> dict[str, Any]:
    """``file``'s JSON object."""
    try:
        data = json.loads(_read(file))
    except (ValueError, RecursionError) as error:  # ValueError: a UnicodeDecodeError too
        raise DamagedRun(f"{file}: not valid JSON ({error})") from None
    if not isinstance(data, dict):
        raise DamagedRun(f"{file}: holds {_json_kind(data)}, not an object")
    return data


def _json_kind(value: Any) -> str:
    if isinstance(value, bool):
        return BOOLEAN
    if isinstance(value, int) and abs(value) > sys.float_info.max:
        return "too large a number"
    if isinstance(value, (int, float)):
        return NUMBER
    if isinstance(value, str):
        return STRING
    if isinstance(value, dict):
        return OBJECT
    return "a list" if isinstance(value, list) else NULL


def _field(data: dict[str, Any], key: str, kinds: tuple[str, ...], where: str, required: bool = True) -> Any:
    """``data[key]`` when its JSON kind is one of ``kinds``, None when it is absent and not ``required``; else
    :class:`DamagedRun` naming ``where`` (the file and the keys above ``key``)."""
    if key not in data:
        if required:
            raise DamagedRun(f"{where}no {key!r}")
        return None
    kind = _json_kind(data[key])
    if kind not in kinds:
        raise DamagedRun(f"{where}{key!r} is {kind}, not {' or '.join(kinds)}")
    return data[key]


def _photo(run: Path) -> str:
    """The run's photo: from ``run.json``; for a failed run (none published), from Hydra's config when it is
    readable, else unknown (empty)."""
    if (run / "run.json").is_file():
        return str(_field(_json_object(run / "run.json"), "photo", (STRING,), f"{run / 'run.json'}: "))
    config = run / ".hydra" / "config.yaml"
    try:
        data = yaml.safe_load(config.read_text(encoding="utf-8")) if config.is_file() else None
    except (OSError, ValueError, yaml.YAMLError):
        data = None
    return str(data.get("image", "")) if isinstance(data, dict) else ""


def _last_error(log: Path) -> str:
    lines = _read(log).decode(errors="replace").splitlines() if log.is_file() else []
    errors = [line.split("]", 3)[-1].strip() for line in lines if "[ERROR]" in line]
    return errors[-1] if errors else "no metrics.json (the run stopped before publishing)"


def _figures(metrics: dict[str, Any], where: str) -> dict[str, Any]:
    """A published run's row figures from its ``metrics.json`` (``where``: the file, for the reasons of
    :class:`DamagedRun`)."""
    stages = _field(metrics, "stages", (OBJECT,), where)
    computed: dict[str, float] = {}
    cached: list[str] = []
    for name in stages:
        stage = _field(stages, name, (OBJECT,), f"{where}'stages': ")
        seconds = _field(stage, "compute_seconds", (NUMBER,), f"{where}'stages': {name!r}: ", required=False)
        if _field(stage, "cached", (BOOLEAN,), f"{where}'stages': {name!r}: ", required=False):
            cached.append(name)
        computed[name] = 0.0 if name in cached else float(seconds or 0.0)  # no compute_seconds: 0
    implementations = _field(metrics, "implementations", (OBJECT,), where)
    chosen = {
        kind: _field(
            _field(implementations, kind, (OBJECT,), f"{where}'implementations': "),
            "name",
            (STRING,),
            f"{where}'implementations': {kind!r}: ",
        )
        for kind in sorted(implementations)
    }
    objects_log = _field(metrics, "fit_objects_log", (OBJECT,), where, required=False) or {}
    fit = _field(metrics, "fit_appearance_log", (OBJECT,), where, required=False) or {}
    return {
        "implementations": " ".join(f"{kind}={name}" for kind, name in chosen.items()),
        "vfov_deg": _field(metrics, "vfov_deg", (NUMBER, NULL), where, required=False),
        "objects": _field(objects_log, "objects", (NUMBER, NULL), f"{where}'fit_objects_log': ", required=False),
        "total_seconds": _field(metrics, "total_seconds", (NUMBER,), where),
        "computed_seconds": round(sum(computed.values()), 4),
        "cached_stages": " ".join(cached),
        "stages": computed,
        **{key: _field(fit, key, (NUMBER, NULL), f"{where}'fit_appearance_log': ", required=False) for key in FIT_KEYS},
    }


def summarise(run: Path) -> dict[str, Any]:
    """One run folder's row (plain values; ``stages``: stage → seconds computed by this run, 0 for a stage whose
    result came from the cache; ``cached``: those stages). A run whose ``run.json`` or ``metrics.json`` is
    damaged is a failed row whose error names the file and what is wrong."""
    row: dict[str, Any] = {"run": str(run), "stages": {}}
    metrics_file = run / "metrics.json"
    try:
        row["photo"] = _photo(run)
        if not metrics_file.is_file():
            return {**row, "status": "failed", "error": _last_error(run / "psdr-room.log")}
        return {**row, **_figures(_json_object(metrics_file), f"{metrics_file}: "), "status": "ok"}
    except DamagedRun as damage:
        return {**row, "status": "failed", "error": str(damage)}


COLUMNS = (
    "run",
    "photo",
    "status",
    "error",
    "implementations",
    "vfov_deg",
    "objects",
    "rmse_init",
    "rmse",
    "ssim_init",
    "ssim",
    "flip_init",
    "flip",
    "total_seconds",
    "computed_seconds",
    "cached_stages",
)


def _stage_names(rows: list[dict[str, Any]]) -> list[str]:
    """Every stage any row has, in the order the runs met them."""
    return list(dict.fromkeys(name for row in rows for name in row["stages"]))


def csv_text(rows: list[dict[str, Any]]) -> str:
    """The rows as CSV: :data:`COLUMNS`, then one ``<stage>_s`` column per stage any run has (seconds computed by
    the run; 0 for a cached stage, which ``cached_stages`` names)."""
    stages = _stage_names(rows)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([*COLUMNS, *(f"{s}_s" for s in stages)])
    for row in rows:
        writer.writerow([_plain(row.get(c)) for c in COLUMNS] + [_plain(row["stages"].get(s)) for s in stages])
    return out.getvalue()


def _plain(value: Any) -> str:
    return "" if value is None else f"{value:.4g}" if isinstance(value, float) else str(value)


def _thumbnail(run: Path) -> str:
    """photo | render (the render when the run got that far) as a PNG data URI; empty when there is no photo."""
    files = [run / "artifacts" / name for name in ("image/image.png", "appearance/render.png")]
    read = [cv2.imread(str(f)) for f in files if f.is_file()]
    images = [
        cv2.resize(i, (round(i.shape[1] * THUMB_HEIGHT / i.shape[0]), THUMB_HEIGHT), interpolation=cv2.INTER_AREA)
        for i in read
        if i is not None
    ]
    if not images:
        return ""
    ok, png = cv2.imencode(".png", np.hstack(images))
    return "data:image/png;base64," + base64.b64encode(png.tobytes()).decode() if ok else ""


def _link(target: Path, base: Path) -> str:
    """``target`` as a link from a page in ``base``: relative where it can be (a sweep folder moves whole)."""
    try:
        return Path(os.path.relpath(target, base)).as_posix()
    except ValueError:  # another drive (Windows)
        return target.absolute().as_uri()


def _stage_cells(row: dict[str, Any]) -> str:
    """A run's stages in run order, each ``name seconds`` computed, or ``name cached`` (greyed)."""
    cached = set(row.get("cached_stages", "").split())
    return " ".join(
        f'<span class="cached">{html.escape(name)} cached</span>'
        if name in cached
        else f"<span>{html.escape(name)} {seconds:.2f} s</span>"
        for name, seconds in row["stages"].items()
    )


def html_text(rows: list[dict[str, Any]], base: Path = Path(".")) -> str:
    """The rows as one self-contained HTML page that fits 1400 px: a run's summary, then its implementations and
    stages on a detail row; each photo | render thumbnail opens the run's ``report.html`` (linked from ``base``, the page's folder)."""

    def pair(row: dict[str, Any], key: str) -> str:
        a, b = row.get(f"{key}_init"), row.get(key)
        return "" if a is None or b is None else f"{a:.3f} → {b:.3f}"

    body = []
    for row in rows:
        run = Path(row["run"])
        uri = _thumbnail(run)
        thumb = f'<img src="{uri}">' if uri else ""
        if thumb and (run / "report.html").is_file():
            thumb = (
                f'<a href="{html.escape(_link(run / "report.html", base))}" title="the report of this run">{thumb}</a>'
            )
        status = row["status"] if row["status"] == "ok" else f"{row['status']}: {row.get('error', '')}"
        photo = Path(str(row.get("photo", ""))).name or "(unknown photo)"
        cells = [
            thumb,
            f"<b>{html.escape(photo)}</b><br><small>{html.escape(str(run))}</small>",
            html.escape(status),
            _plain(row.get("vfov_deg")),
            _plain(row.get("objects")),
            pair(row, "rmse"),
            pair(row, "ssim"),
            pair(row, "flip"),
            _plain(row.get("computed_seconds")),
            _plain(row.get("total_seconds")),
        ]
        body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        details = [f"<small>{html.escape(row['implementations'])}</small>"] if row.get("implementations") else []
        details += [_stage_cells(row)] if row["stages"] else []
        if details:
            body.append(
                f'<tr class="stages"><td></td><td colspan="{len(PAGE_COLUMNS) - 1}">{"<br>".join(details)}</td></tr>'
            )
    ok = sum(row["status"] == "ok" for row in rows)
    computed = sum(float(row.get("computed_seconds") or 0.0) for row in rows)
    results = sum(len(row["stages"]) for row in rows)
    cached = sum(len(row.get("cached_stages", "").split()) for row in rows)
    return (
        "<!doctype html><meta charset='utf-8'><title>psdr-room summary</title>"
        "<style>body{font:13px sans-serif}table{border-collapse:collapse;width:100%;table-layout:fixed}"
        "td,th{border:1px solid #ccc;padding:2px 6px;vertical-align:top}td small{overflow-wrap:anywhere}"
        "small{color:#555}td{overflow-wrap:anywhere}img{max-width:100%}tr.stages td{border-top:none;color:#333}"
        "tr.stages span{margin-right:1.2em;white-space:nowrap}span.cached{color:#999}</style>"
        f"<h1>psdr-room summary</h1><p>{len(rows)} runs, {ok} ok, {len(rows) - ok} failed; {computed:.1f} s computed "
        f"in all; {cached} of {results} stage results from the cache (0 s each: their cost was paid by the run that "
        "made them). Per run: computed s = the seconds its stages computed; wall s = its stages' wall time, cache "
        "reads included.</p><table><colgroup>"
        + "".join(f'<col style="width:{w}">' for _, w in PAGE_COLUMNS)
        + "</colgroup>"
        "<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h, _ in PAGE_COLUMNS) + "</tr>" + "".join(body) + "</table>\n"
    )


def write_summary(rows: list[dict[str, Any]], out: Path) -> str:
    """Write ``summary.csv`` and ``summary.html`` into ``out``, both or neither (each written beside its place, then
    renamed into it); return the line that reports them, with one more line per failed run."""
    if not out.is_dir():
        raise PsdrRoomError(f"--out {out}: not a folder; create it or pick another")
    texts = {"summary.csv": csv_text(rows), "summary.html": html_text(rows, out)}
    for name in texts:
        if (out / name).exists() and not (out / name).is_file():
            raise PsdrRoomError(f"--out {out}: {name} there is not a file; move it away or pick another folder")
    staged: dict[str, Path] = {}
    try:
        for name, text in texts.items():
            staged[name] = out / f".{name}.{os.getpid()}.partial"
            with staged[name].open("x", encoding="utf-8") as stream:
                stream.write(text)
        for name, partial in staged.items():
            os.replace(partial, out / name)
    except OSError as error:
        raise PsdrRoomError(f"--out {out}: cannot write {name} there ({error.strerror}); pick another folder") from None
    finally:
        for partial in staged.values():
            partial.unlink(missing_ok=True)
    failed = [row for row in rows if row["status"] != "ok"]
    return "\n".join(
        [
            f"{len(rows)} runs ({len(rows) - len(failed)} ok, {len(failed)} failed) → "
            f"{out / 'summary.csv'}, {out / 'summary.html'}",
            *(f"  failed: {row.get('photo') or row['run']}: {row.get('error', '')}" for row in failed),
        ]
    )


class SweepSummary(Callback):
    """Hydra callback: at the end of a ``--multirun`` sweep, the summary of its jobs in the sweep folder.

    Jobs catch their own errors (a failed photo does not stop the others, see ``psdr_room_core.engine.cli``), so
    this is where a sweep with a failed job ends with exit status 1. It also removes the empty folder named
    literally ``.submitit/%j`` that submitit's executors make from their folder setting before any job puts its id
    in place of ``%j`` (each job's logs are in ``.submitit/<job id>/``).
    """

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        placeholder = sweep_dir / ".submitit" / "%j"
        if placeholder.is_dir() and not any(placeholder.iterdir()):
            placeholder.rmdir()
        try:
            rows = [summarise(run) for run in find_runs([sweep_dir])]
            report = write_summary(rows, sweep_dir)
        except PsdrRoomError as error:
            print(f"psdr-room: sweep summary: {error}", file=sys.stderr)
            sys.exit(1)
        print(f"psdr-room: sweep: {report}", file=sys.stderr)
        if any(row["status"] != "ok" for row in rows):
            sys.exit(1)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``psdr-room-summary``."""
    parser = argparse.ArgumentParser(prog="psdr-room-summary", description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN_DIR", help="run folders, or folders holding them")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("."),
        help="where summary.csv and summary.html go (default: the current folder)",
    )
    args = parser.parse_args(argv)
    try:
        print(write_summary([summarise(run) for run in find_runs(args.runs)], args.out))
    except PsdrRoomError as error:
        print(f"psdr-room-summary: error: {error}", file=sys.stderr)
        return error.exit_code
    return 0


if __name__ == "__main__":
    sys.exit(main())
