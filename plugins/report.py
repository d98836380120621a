"""``report.html``: a self-contained page per run with the input, the estimates drawn over it, and the
stage timings and cache hits (written by the ``after_run`` hook)."""

from __future__ import annotations

import base64
import html
import os
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.dag import RunRecord
from psdr_room_core.hookspecs import hookimpl
from psdr_room_core.visualize import depth_colormap, legend, room_edges_overlay, segment_overlay


def _png(rgb8: np.ndarray) -> str:
    ok, data = cv2.imencode(".png", np.ascontiguousarray(rgb8[..., ::-1]))
    assert ok
    return "data:image/png;base64," + base64.b64encode(data.tobytes()).decode("ascii")


def _figures(run: RunRecord, alpha: float) -> list[tuple[str, np.ndarray]]:
    art = run.artifacts
    image = art.get("image")
    if image is None:
        return []
    rgb8 = image.to_uint8()
    figures = [("input (working resolution)", rgb8)]
    if "panoptic" in art:
        overlay = segment_overlay(rgb8, art["panoptic"], alpha)
        pad = np.full((legend().shape[0], overlay.shape[1], 3), 255, np.uint8)
        strip = legend()[:, : overlay.shape[1]]
        pad[:, : strip.shape[1]] = strip
        figures.append(("segmentation", np.vstack([overlay, pad])))
    if "depth" in art:
        figures.append(("depth", depth_colormap(art["depth"].depth, art["depth"].valid)))
    if "camera" in art and "room_box" in art:
        figures.append(("room box (room_init)", room_edges_overlay(rgb8, art["camera"], art["room_box"])))
    if getattr(art.get("object_candidates"), "sheet", None) is not None:
        figures.append(("retrieval: object crop, then the top-k models (score)", art["object_candidates"].sheet))
    for name, artifact in art.items():
        if artifact.kind in ("optimization_log", "materials"):
            figures += [(f"{name}: {title}", picture) for title, picture in artifact.images.items()]
    return figures


def render_report(run: RunRecord, alpha: float) -> str:
    """The report page as HTML text (images embedded as data URLs)."""
    rows = "".join(
        f"<tr><td>{html.escape(r.name)}</td><td>{r.seconds:.2f}</td><td>{r.compute_seconds:.2f}</td>"
        f"<td>{'cached' if r.cached else 'computed'}</td>"
        f"<td>{html.escape(', '.join(f'{c}={n}' for c, n in r.implementations.items()))}</td>"
        f"<td><code>{r.key[:12]}</code></td></tr>"
        for r in run.stages
    )
    facts = []
    camera = run.artifacts.get("camera")
    if camera is not None:
        facts.append(f"vertical FoV {camera.vfov_deg:.2f}° ({html.escape(camera.method)}, confidence {camera.confidence:.2f})")
        if "camera_fit" in run.artifacts:
            facts.append(f"vertical FoV after room_fit {run.artifacts['camera_fit'].vfov_deg:.2f}°")
    room = run.artifacts.get("room_box_fit", run.artifacts.get("room_box"))
    if room is not None:
        size = " × ".join(f"{2 * h:.2f}" for h in room.half_size)
        facts.append(f"room box {size} (x × y × z), camera height {room.extra.get('camera_height', float('nan')):.2f}")
    figures = "".join(
        f'<figure><img src="{_png(img)}" alt="{html.escape(title)}"><figcaption>{html.escape(title)}</figcaption></figure>'
        for title, img in _figures(run, alpha)
    )
    impls = "".join(
        f"<li>{html.escape(c)} = <b>{html.escape(d['name'])}</b> v{html.escape(d['version'])} — {html.escape(d['origin'])}"
        + (f"<br><small>selected by {html.escape(d['selected_by'])}</small>" if "selected_by" in d else "") + "</li>"
        for c, d in run.implementations.items()
    )
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>psdr-room: {html.escape(run.photo.name)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em; color: #222; }}
figure {{ display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }}
img {{ max-width: 480px; border: 1px solid #ccc; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }}
</style></head><body>
<h1>psdr-room report</h1>
<p>photo: <code>{html.escape(str(run.photo))}</code></p>
<ul>{"".join(f"<li>{f}</li>" for f in facts)}</ul>
{figures}
<h2>stages</h2>
<table><tr><th>stage</th><th>this run (s)</th><th>compute (s)</th><th>cache</th><th>implementations</th><th>key</th></tr>
{rows}</table>
<h2>implementations</h2><ul>{impls}</ul>
</body></html>
"""


@hookimpl
def after_run(run: RunRecord, run_dir: Path) -> None:
    settings = run.config.get("report", {})
    if not settings.get("enabled", True):
        return
    target = run_dir / "report.html"
    tmp = target.with_name(".report.html.tmp")
    tmp.write_text(render_report(run, float(settings.get("overlay_alpha", 0.45))))
    os.replace(tmp, target)
