"""``report.html``: a self-contained page per run (written by the ``after_run`` hook): the photo against the
final render (a slider), the metrics, every stage's pictures in pipeline order (estimates over the photo,
fits before/after, crop pairs at initialisation and after the fit, loss curves), the stage timings and
cache hits, and the implementation used for every capability. Images are embedded as data URLs; a small
script checks on load that every one of them decoded and logs an error otherwise."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.files import write_whole
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.records import RunRecord
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting
from psdr_room_core.method.artifacts import (
    Camera,
    DepthMap,
    Image,
    Lights,
    MaterialAssignment,
    ObjectCandidates,
    OptimizationLog,
    Panoptic,
    RoomBox,
    SceneAppearance,
)
from psdr_room_core.method.guesses import guesses
from psdr_room_core.method.visualize import depth_colormap, legend, room_edges_overlay, segment_overlay

PICTURE_TYPES = (OptimizationLog, MaterialAssignment, Lights)
"""Artifact types whose ``images`` the report shows."""

STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em; color: #222; max-width: 1400px; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }
figure img { max-width: 480px; border: 1px solid #ccc; image-rendering: pixelated; }
table { border-collapse: collapse; } td, th { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
.compare { position: relative; display: inline-block; line-height: 0; }
.compare img { width: 640px; height: auto; border: 1px solid #ccc; image-rendering: pixelated; }
.compare .top { position: absolute; left: 0; top: 0; clip-path: inset(0 50% 0 0); }
"""

SCRIPT = """
const slider = document.getElementById('slider');
if (slider) {
  slider.addEventListener('input', () => {
    document.querySelector('.compare .top').style.clipPath = `inset(0 ${100 - slider.value}% 0 0)`;
  });
}
window.addEventListener('load', () => {
  const images = Array.from(document.images);
  const broken = images.filter(img => !(img.complete && img.naturalWidth > 0));
  broken.forEach(img => console.error('report image did not load: ' + img.alt));
  document.body.dataset.images = `${images.length - broken.length}/${images.length}`;
});
"""


def _png(rgb8: np.ndarray) -> str:
    ok, data = cv2.imencode(".png", np.ascontiguousarray(rgb8[..., ::-1]))
    assert ok
    return "data:image/png;base64," + base64.b64encode(data.tobytes()).decode("ascii")


def _figures(run: RunRecord, alpha: float) -> list[tuple[str, np.ndarray]]:
    """(title, picture) of every stage, in pipeline order."""
    image = run.artifact("image", Image)
    if image is None:
        return []
    rgb8 = image.to_uint8()
    figures = [("input (working resolution)", rgb8)]
    panoptic, depth = run.artifact("panoptic", Panoptic), run.artifact("depth", DepthMap)
    camera, room = run.artifact("camera", Camera), run.artifact("room_box", RoomBox)
    candidates = run.artifact("object_candidates", ObjectCandidates)
    if panoptic is not None:
        overlay = segment_overlay(rgb8, panoptic, alpha)
        pad = np.full((legend().shape[0], overlay.shape[1], 3), 255, np.uint8)
        strip = legend()[:, : overlay.shape[1]]
        pad[:, : strip.shape[1]] = strip
        figures.append(("segmentation", np.vstack([overlay, pad])))
    if depth is not None:
        figures.append(("depth", depth_colormap(depth.depth, depth.valid)))
    if camera is not None and room is not None:
        figures.append(("room box (room_init)", room_edges_overlay(rgb8, camera, room)))
    if candidates is not None and candidates.sheet is not None:
        figures.append(("retrieval: object crop, then the top-k models (score)", candidates.sheet))
    for name, artifact in run.artifacts.items():
        if isinstance(artifact, PICTURE_TYPES):
            figures += [(f"{name}: {title}", picture) for title, picture in artifact.images.items()]
    return figures


def _comparison(run: RunRecord) -> str:
    """The photo and the final render, one over the other, with a slider between them."""
    image, appearance = run.artifact("image", Image), run.artifact("appearance", SceneAppearance)
    if image is None or appearance is None or "render" not in appearance.images:
        return ""
    render = appearance.images["render"]
    photo = cv2.resize(image.to_uint8(), (render.shape[1], render.shape[0]), interpolation=cv2.INTER_AREA)
    return (
        f'<h2>photo | render</h2><div class="compare"><img src="{_png(photo)}" alt="photo">'
        f'<img class="top" src="{_png(render)}" alt="final render"></div><br>'
        '<label>render ◀ ▶ photo <input id="slider" type="range" min="0" max="100" value="50"></label>'
    )


def _metric_rows(run: RunRecord) -> str:
    """One row per optimisation log of the run: its summary's numbers."""
    rows = []
    for stage, artifact in run.artifacts.items():
        if isinstance(artifact, OptimizationLog):
            summary = artifact.summary
            cells = ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in summary.items()
                if isinstance(v, (int, float, str))
            )
            rows.append(f"<tr><td>{html.escape(stage)}</td><td>{html.escape(cells)}</td></tr>")
    return "".join(rows)


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
    camera = run.artifact("camera", Camera)
    if camera is not None:
        facts.append(
            f"vertical FoV {camera.vfov_deg:.2f}° ({html.escape(camera.method)}, confidence {camera.confidence:.2f})"
        )
        fitted = run.artifact("camera_fit", Camera)
        if fitted is not None:
            facts.append(f"vertical FoV after room_fit {fitted.vfov_deg:.2f}°")
    room = run.artifact(("room_box_objects", "room_box_fit", "room_box"), RoomBox)
    if room is not None:
        size = " × ".join(f"{2 * h:.2f}" for h in room.half_size)
        facts.append(f"room box {size} (x × y × z), camera height {room.extra.get('camera_height', float('nan')):.2f}")
        facts.extend(f"guessed: {html.escape(guess)}" for guess in guesses(camera, run.artifact("room_box", RoomBox)))
    fit = run.artifact("fit_appearance_log", OptimizationLog)
    if fit is not None and "rmse" in fit.summary:
        s = fit.summary
        perceptual = (
            f"LPIPS {s['lpips_init']:.3f} → {s['lpips']:.3f}"
            if "lpips" in s
            else "LPIPS: not computed (psdr-room-models download alexnet_imagenet lpips_alex_v01 installs it)"
        )
        flip = f", ꟻLIP {s['flip_init']:.3f} → {s['flip']:.3f}" if "flip" in s else ""
        facts.append(
            f"RMSE (1/8 size) {s['rmse_init']:.4f} → {s['rmse']:.4f}, SSIM {s['ssim_init']:.3f} → "
            f"{s['ssim']:.3f}{flip}; {perceptual}"
        )
        if "denoiser" in s:
            facts.append(f"renders denoised by: {s['denoiser']}")
    figures = "".join(
        f'<figure><img src="{_png(img)}" alt="{html.escape(title)}"><figcaption>{html.escape(title)}</figcaption></figure>'
        for title, img in _figures(run, alpha)
    )
    impls = "".join(
        f"<li>{html.escape(c)} = <b>{html.escape(d['name'])}</b> v{html.escape(d['version'])} — {html.escape(d['origin'])}"
        + (f"<br><small>selected by {html.escape(d['selected_by'])}</small>" if "selected_by" in d else "")
        + "</li>"
        for c, d in run.implementations.items()
    )
    total = sum(r.seconds for r in run.stages)
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>psdr-room: {html.escape(run.photo.name)}</title>
<link rel="icon" href="data:,">
<style>{STYLE}</style></head><body>
<h1>psdr-room report</h1>
<p>photo: <code>{html.escape(str(run.photo))}</code></p>
<ul>{"".join(f"<li>{f}</li>" for f in facts)}</ul>
{_comparison(run)}
<h2>stages</h2>
{figures}
<h2>optimisation summaries</h2>
<table><tr><th>log</th><th>summary</th></tr>{_metric_rows(run)}</table>
<h2>timings</h2>
<table><tr><th>stage</th><th>this run (s)</th><th>compute (s)</th><th>cache</th><th>implementations</th><th>key</th></tr>
{rows}<tr><td><b>total</b></td><td>{total:.2f}</td><td></td><td></td><td></td><td></td></tr></table>
<h2>implementations</h2><ul>{impls}</ul>
<script>{SCRIPT}</script>
</body></html>
"""


@dataclass
class ReportSettings:
    """The ``report`` node of the config."""

    enabled: bool = setting(doc="Write report.html into the run directory.")
    overlay_alpha: float = setting(ge=0, le=1, doc="Opacity of the segmentation drawn over the photo.")


@hookimpl
def register_settings(registry: Registry) -> None:
    """The report's settings (``report.enabled``, ``report.overlay_alpha``)."""
    registry.add_settings("report", ReportSettings)


@hookimpl
def after_run(run: RunRecord, run_dir: Path) -> None:
    settings = run.config.get("report", {})
    if not settings.get("enabled", True):
        return
    write_whole(run_dir / "report.html", render_report(run, float(settings.get("overlay_alpha", 0.45))))
