"""Console progress: one line per stage when it is done (time, cached or computed) and a closing summary."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.records import RunRecord, StageRecord

log = logging.getLogger("psdr_room")


@hookimpl
def before_stage(record: StageRecord, inputs: dict[str, Any]) -> None:
    log.info("▶ %-16s running (key %s)", record.name, record.key[:12])


@hookimpl
def after_stage(record: StageRecord, outputs: dict[str, Any]) -> None:
    how = "cached" if record.cached else "computed"
    impls = ", ".join(f"{c}={n}" for c, n in record.implementations.items())
    log.info("✓ %-16s %7.2f s  %-8s %s", record.name, record.seconds, how, impls)


@hookimpl
def on_stage_error(record: StageRecord, error: BaseException) -> None:
    log.info("✗ %-16s failed", record.name)


@hookimpl
def after_run(run: RunRecord, run_dir: Path) -> None:
    cached = sum(r.cached for r in run.stages)
    total = sum(r.seconds for r in run.stages)
    peak = max((r.peak_rss_mb for r in run.stages), default=0.0)
    log.info(
        "done: %d stages (%d cached) in %.2f s, peak memory %.0f MiB → %s",
        len(run.stages),
        cached,
        total,
        peak,
        run_dir,
    )
