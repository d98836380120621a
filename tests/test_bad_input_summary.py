"""``psdr-room-summary`` over damaged runs and bad arguments: a run whose ``metrics.json`` or ``run.json`` is not
as psdr-room writes it is a failed row with its reason, and the other runs are summarised; a missing folder, a
folder without runs and an ``--out`` that cannot take the summary each get one ``psdr-room-summary: error:`` line.
The run folders are written by hand, in the form :func:`psdr_room_core.engine.run.publish` gives them."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from bad_input import Case, run_case

PROGRAM = "psdr-room-summary"
METRICS = {
    "stages": {
        "load_image": {"seconds": 0.5, "compute_seconds": 0.4, "peak_rss_mb": 310.2, "cached": False, "key": "a1"},
        "estimate_fov": {"seconds": 0.1, "compute_seconds": 0.0, "peak_rss_mb": 312.0, "cached": True, "key": "b2"},
    },
    "total_seconds": 0.6,
    "implementations": {"fov": {"name": "fixed"}},
    "digests": {},
    "vfov_deg": 60.0,
    "fit_objects_log": {"objects": 3},
    "fit_appearance_log": {"rmse_init": 0.2, "rmse": 0.1, "ssim_init": 0.5, "ssim": 0.7, "flip_init": 0.3, "flip": 0.2},
}
GOOD = json.dumps(METRICS, indent=2).encode() + b"\n"


def run_folder(parent: Path, name: str, metrics: bytes | None = None, run: bytes | None = None) -> Path:
    """A published run folder ``parent/name``: ``metrics.json`` and ``run.json`` as given, else as psdr-room writes them."""
    folder = parent / name
    folder.mkdir(parents=True)
    (folder / "metrics.json").write_bytes(GOOD if metrics is None else metrics)
    photo = {"photo": f"/photos/{name}.jpg", "implementations": METRICS["implementations"], "stages": [], "config": {}}
    (folder / "run.json").write_bytes(json.dumps(photo).encode() + b"\n" if run is None else run)
    return folder


def metrics_with(**changes: object) -> bytes:
    return json.dumps({**METRICS, **changes}).encode()


def metrics_without(key: str) -> bytes:
    return json.dumps({k: v for k, v in METRICS.items() if k != key}).encode()


DAMAGED: dict[str, tuple[dict[str, bytes], str]] = {
    "metrics_a_list": ({"metrics": b"[1, 2, 3]"}, "metrics.json: holds a list, not an object"),
    "metrics_truncated": ({"metrics": GOOD[: len(GOOD) // 2]}, "metrics.json: not valid JSON"),
    "metrics_not_json": ({"metrics": b"stages: yes"}, "metrics.json: not valid JSON"),
    "metrics_empty": ({"metrics": b""}, "metrics.json: not valid JSON"),
    "metrics_not_utf8": ({"metrics": b'{"vfov_deg": "\xff"}'}, "metrics.json: not valid JSON"),
    "metrics_nested_deeply": ({"metrics": b"[" * 100_000}, "metrics.json: not valid JSON"),
    "metrics_without_stages": ({"metrics": metrics_without("stages")}, "metrics.json: no 'stages'"),
    "metrics_stages_a_list": ({"metrics": metrics_with(stages=["load_image"])}, "'stages' is a list, not an object"),
    "metrics_stage_a_number": ({"metrics": metrics_with(stages={"load_image": 3})}, "'load_image' is a number"),
    "metrics_seconds_a_string": (
        {"metrics": metrics_with(stages={"load_image": {"compute_seconds": "fast", "cached": False}})},
        "'compute_seconds' is a string, not a number",
    ),
    "metrics_seconds_too_large": (
        {"metrics": metrics_with(total_seconds=10**400)},
        "'total_seconds' is too large a number, not a number",
    ),
    "metrics_fov_a_string": ({"metrics": metrics_with(vfov_deg="wide")}, "'vfov_deg' is a string, not a number"),
    "metrics_implementation_nameless": (
        {"metrics": metrics_with(implementations={"fov": {}})},
        "'fov': no 'name'",
    ),
    "metrics_fit_log_a_list": (
        {"metrics": metrics_with(fit_appearance_log=[0.1])},
        "'fit_appearance_log' is a list, not an object",
    ),
    "metrics_ssim_a_bool": (
        {"metrics": metrics_with(fit_appearance_log={"ssim": True})},
        "'ssim' is true or false, not a number",
    ),
    "run_json_damaged": ({"run": b'{"photo": "/photos/x.jpg", "implementa'}, "run.json: not valid JSON"),
    "run_json_a_list": ({"run": b'["/photos/x.jpg"]'}, "run.json: holds a list, not an object"),
    "run_json_photo_a_number": ({"run": b'{"photo": 7}'}, "run.json: 'photo' is a number, not a string"),
}
"""Run folder name → its damaged file(s) (``metrics`` / ``run`` content) and the reason its row gives."""


def summary(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [shutil.which(PROGRAM) or PROGRAM, *args], env=env, capture_output=True, text=True, timeout=120
    )


def test_damaged_runs_are_failed_rows_and_the_good_run_is_summarised(tmp_path: Path, cli_env: dict[str, str]) -> None:
    sweep = tmp_path / "sweep"
    run_folder(sweep, "good")
    for name, (files, _) in DAMAGED.items():
        run_folder(sweep, name, **files)
    result = summary(str(sweep), "--out", str(tmp_path), env=cli_env)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    assert f"{len(DAMAGED) + 1} runs (1 ok, {len(DAMAGED)} failed)" in result.stdout
    rows = {Path(row["run"]).name: row for row in csv.DictReader((tmp_path / "summary.csv").open(encoding="utf-8"))}
    good = rows.pop("good")
    assert good["status"] == "ok" and good["photo"] == "/photos/good.jpg" and good["implementations"] == "fov=fixed"
    assert float(good["vfov_deg"]) == 60.0 and good["objects"] == "3" and float(good["ssim"]) == 0.7
    assert good["cached_stages"] == "estimate_fov" and float(good["load_image_s"]) == 0.4
    assert sorted(rows) == sorted(DAMAGED)
    page = (tmp_path / "summary.html").read_text(encoding="utf-8")
    for name, (_, reason) in DAMAGED.items():
        row = rows[name]
        assert row["status"] == "failed" and reason in row["error"], (name, row["error"])
        assert row["rmse"] == "" and row["computed_seconds"] == "", name
        assert f"failed: {row['photo'] or row['run']}: {row['error']}" in result.stdout, name
        assert reason in page.replace("&#x27;", "'"), name
    assert rows["metrics_a_list"]["photo"] == "/photos/metrics_a_list.jpg"  # run.json still names the photo


def test_a_damaged_log_beside_no_metrics_is_a_failed_row(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A run that failed before publishing: its photo from Hydra's config, its reason from the log; damaged, the
    photo is unknown and the reason is the log's absence of an error."""
    run_folder(tmp_path / "runs", "good")
    failed = tmp_path / "runs" / "failed"
    (failed / ".hydra").mkdir(parents=True)
    (failed / ".hydra" / "config.yaml").write_text("- not: a mapping\n")
    (failed / "psdr-room.log").write_bytes(b"\xff\xfe not a log\n")
    result = summary(str(tmp_path / "runs"), "--out", str(tmp_path), env=cli_env)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    assert "2 runs (1 ok, 1 failed)" in result.stdout and "stopped before publishing" in result.stdout


def good_runs(folder: Path) -> str:
    return str(run_folder(folder, "good").parent)


def out_with_a_folder_named(name: str) -> Callable[[Path], list[str]]:
    """The good run and an ``--out`` folder where ``name`` is a folder of the user's: the summary cannot go there."""

    def setup(folder: Path) -> list[str]:
        (folder / "out" / name).mkdir(parents=True)
        (folder / "out" / name / "mine.txt").write_text("the user's")
        return [good_runs(folder / "runs"), "--out", str(folder / "out")]

    return setup


def out_is_a_file(folder: Path) -> list[str]:
    (folder / "out.txt").write_text("the user's")
    return [good_runs(folder / "runs"), "--out", str(folder / "out.txt")]


def folder_without_runs(folder: Path) -> list[str]:
    (folder / "empty").mkdir()
    (folder / "empty" / "notes.txt").write_text("the user's")
    return [str(folder / "empty"), "--out", str(folder)]


CASES: dict[str, Case] = {
    "summary_folder_missing": Case(lambda f: [str(f / "nowhere"), "--out", str(f)], "nowhere: not a folder", PROGRAM),
    "summary_folder_without_runs": Case(folder_without_runs, "empty: no run folder in it", PROGRAM),
    "summary_out_not_a_folder": Case(out_is_a_file, "out.txt: not a folder", PROGRAM),
    "summary_out_missing": Case(
        lambda f: [good_runs(f / "runs"), "--out", str(f / "no" / "such")], "such: not a folder", PROGRAM
    ),
    "summary_out_csv_is_a_folder": Case(out_with_a_folder_named("summary.csv"), "summary.csv", PROGRAM),
    "summary_out_html_is_a_folder": Case(out_with_a_folder_named("summary.html"), "summary.html", PROGRAM),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_summary_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)
