"""The engine knows nothing of rooms: a two-stage toy pipeline with its own artifact type and capability runs,
is cached and published with only ``psdr_room_core.engine`` imported (the method, the plugins and the
rendering stack are blocked from importing)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

SCRIPT = textwrap.dedent("""
    import importlib.abc, sys
    from pathlib import Path

    BLOCKED = ("psdr_room_core.method", "psdr_room_plugins", "mitsuba", "drjit", "torch", "open3d", "onnxruntime")

    class Block(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name.startswith(BLOCKED):
                raise ImportError(f"the engine imported {name}")

    sys.meta_path.insert(0, Block())
    sys.path.insert(0, sys.argv[1])
    work = Path(sys.argv[2])

    from omegaconf import OmegaConf
    import toy_plugin
    from psdr_room_core.engine.plugins import load_plugins
    from psdr_room_core.engine.registry import Origin
    from psdr_room_core.engine.run import execute

    plugins = load_plugins(extra=[(toy_plugin, Origin("toy", "tests", "toy = toy_plugin"))], discover=False)
    photo = work / "input.bin"
    photo.write_bytes(b"12345")
    cfg = OmegaConf.create({
        "image": str(photo), "seed": 0, "cache": "readwrite", "cache_dir": str(work / "cache"), "inject": {},
        "run": {"only": None, "from": None, "until": None},
        "scaler": {"impl": "toy", "toy": {"factor": 3.0}},
        "a": {"_stage_": "toy_source", "_inputs_": {}, "_outputs_": ["a"], "start": 2.0},
        "b": {"_stage_": "toy_scale", "_inputs_": {"x": "a"}, "_outputs_": ["b"]},
    })
    first = execute(cfg, work / "run1", plugins)
    second = execute(cfg, work / "run2", plugins)
    print(first.artifacts["b"].value, [r.cached for r in first.stages], [r.cached for r in second.stages])
    print(sorted({m.split(".")[1] if m.count(".") else m for m in sys.modules if m.startswith("psdr_room")}))
""")


def test_a_toy_pipeline_on_the_engine_alone(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(Path(__file__).parent), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    values, packages = result.stdout.strip().splitlines()
    assert values == "6.0 [False, False] [True, True]"
    assert packages == "['engine', 'psdr_room_core']"
    metrics = json.loads((tmp_path / "run1" / "metrics.json").read_text())
    assert set(metrics["stages"]) == {"a", "b"} and metrics["implementations"]["scaler"]["name"] == "toy"
    assert all(stage["peak_rss_mb"] > 0 for stage in metrics["stages"].values())
    assert json.loads((tmp_path / "run2" / "artifacts" / "b" / "number.json").read_text()) == {"value": 6.0}
