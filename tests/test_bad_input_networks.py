"""Damaged networks and killed downloads: a network that differs from its recorded sha256 but still loads stops a
run that chose it by name (one line) and makes ``auto`` take its next choice with a warning line; the check
remembers digests by (size, mtime_ns) in psdr-room's cache, never beside the user's file; a download killed
mid-write leaves a scratch file that the next ``psdr-room-models`` command removes, saying so in one line.
Nothing here reaches beyond 127.0.0.1."""

from __future__ import annotations

import hashlib
import http.server
import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from bad_input import Case, example, run_case
from conftest import EXAMPLE, REPO
from psdr_room_core.method import checksums, models

EYES = REPO / "plugins" / "eyes" / "eyes.onnx"
NANODET = REPO / "plugins" / "detectors" / "nanodet.onnx"
MODELS = "psdr-room-models"


# ------------------------------------------------------------------------------------------ networks
def damaged_copy(network: Path, folder: Path) -> Path:
    """A copy of ``network`` and its JSON note in ``folder/net`` with four bytes in the middle of its largest
    weight flipped: onnxruntime still loads it (its sha256 alone tells it from the original)."""
    import onnxruntime as ort

    target = folder / "net" / network.name
    target.parent.mkdir()
    shutil.copy(network.with_suffix(".json"), target.with_suffix(".json"))
    data = bytearray(network.read_bytes())
    weights = max(onnx.load(str(network)).graph.initializer, key=lambda t: len(t.raw_data)).raw_data
    middle = bytes(data).index(weights) + len(weights) // 2
    for i in range(middle, middle + 4):
        data[i] ^= 0x5A
    target.write_bytes(bytes(data))
    ort.InferenceSession(str(target), providers=["CPUExecutionProvider"])  # still loads
    return target


def depth_graph(path: Path) -> Path:
    """A loadable depth network of the ``depth_anything_v2`` signature (disparity 1 + |pixel|²), not the
    published file."""
    nodes = [
        helper.make_node("ReduceSumSquare", ["pixel_values"], ["squares"], axes=[1], keepdims=0),
        helper.make_node("Add", ["squares", "one"], ["predicted_depth"]),
    ]
    graph = helper.make_graph(
        nodes,
        "not_depth_anything",
        [helper.make_tensor_value_info("pixel_values", TensorProto.FLOAT, ["N", 3, "H", "W"])],
        [helper.make_tensor_value_info("predicted_depth", TensorProto.FLOAT, ["N", "H", "W"])],
        [numpy_helper.from_array(np.array(1.0, np.float32), "one")],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    path.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(model, str(path))
    return path


def models_dir_beside(folder: Path) -> Path:
    """A models directory holding another network as ``depth_anything_v2_small.onnx``. It is psdr-room's folder
    (the check remembers its digests there), so it lies beside the user's files, not among them."""
    models_dir = folder.parent / "models"
    depth_graph(models_dir / "depth_anything_v2_small.onnx")
    return models_dir


def eyes_with_note(note: str) -> Callable[[Path], list[str]]:
    """The shipped network, whole, with ``note`` as the eyes.json beside it."""

    def setup(folder: Path) -> list[str]:
        (folder / "net").mkdir()
        shutil.copy(EYES, folder / "net" / "eyes.onnx")
        (folder / "net" / "eyes.json").write_text(note)
        network = folder / "net" / "eyes.onnx"
        return [f"image={example(folder)}", "detector=eyes", f"detector.eyes.path={network}", "run.until=detect"]

    return setup


EYES_SHA = json.loads(EYES.with_suffix(".json").read_text())["sha256"]

CASES: dict[str, Case] = {
    "eyes_detector_damaged": Case(
        lambda folder: [
            f"image={example(folder)}",
            "detector=eyes",
            f"detector.eyes.path={damaged_copy(EYES, folder)}",
            "run.until=detect",
        ],
        "net/eyes.onnx: sha256 ",
    ),
    "eyes_segmentation_damaged": Case(
        lambda folder: [
            f"image={example(folder)}",
            "fov=fixed",
            "detector=none",
            "segmentation=eyes",
            f"segmentation.eyes.path={damaged_copy(EYES, folder)}",
            "run.until=segment",
        ],
        f"does not match the {EYES_SHA[:12]}… recorded in eyes.json; copy it again",
    ),
    "eyes_depth_damaged": Case(
        lambda folder: [
            f"image={example(folder)}",
            "fov=fixed",
            "detector=none",
            "segmentation=eyes",
            "depth=eyes",
            f"depth.eyes.path={damaged_copy(EYES, folder)}",
            "run.until=estimate_depth",
        ],
        f"does not match the {EYES_SHA[:12]}… recorded in eyes.json",
    ),
    "eyes_note_not_json": Case(eyes_with_note('{"sha256": "49af0c3b'), "net/eyes.json: cannot read the note"),
    "eyes_note_sha256_not_hex": Case(
        eyes_with_note(json.dumps({"sha256": "<script>" * 20})), "net/eyes.json: sha256 must be 64 lower-case hex"
    ),
    "nanodet_damaged": Case(
        lambda folder: [
            f"image={example(folder)}",
            "detector=nanodet_onnx",
            f"detector.nanodet_onnx.path={damaged_copy(NANODET, folder)}",
            "run.until=detect",
        ],
        "net/nanodet.onnx: sha256 ",
    ),
    "registry_depth_model_not_as_published": Case(
        lambda folder: [
            f"image={example(folder)}",
            "fov=fixed",
            "detector=none",
            "segmentation=eyes",
            "depth=onnx",
            f"depth.onnx.models_dir={models_dir_beside(folder)}",
            "run.until=estimate_depth",
        ],
        "expected afb6a5c28f3b… (models.json, model 'depth_anything_v2_small'); "
        "run `psdr-room-models download depth_anything_v2_small --force`",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_damaged_network_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)


def psdr_room(args: list[str], env: dict[str, str], program: str = "psdr-room") -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [shutil.which(program) or program, *args], env=env, capture_output=True, text=True, timeout=300
    )


def warnings_in(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if any(w in line.lower() for w in ("error", "warn", "traceback"))]


def test_auto_passes_over_a_damaged_eyes_network_with_a_warning(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """detector=auto: nanodet_eyes uses the damaged network, so NanoDet alone answers, and one line says why."""
    copy = damaged_copy(EYES, tmp_path)
    args = [f"image={example(tmp_path)}", f"detector.eyes.path={copy}", "run.until=detect"]
    result = psdr_room([*args, f"hydra.run.dir={tmp_path / 'run'}"], cli_env)
    assert result.returncode == 0, result.stderr
    lines = warnings_in(result.stderr)
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"psdr-room: warning: {copy}: sha256 ") and "recorded in eyes.json" in lines[0]
    assert "auto takes its next choice" in lines[0] and "detector=nanodet_onnx" in result.stderr


def test_auto_passes_over_a_registry_model_not_as_published(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """depth=auto: the ONNX depth network's file differs from the registry's sha256, so the next choice (the
    example's depth file) answers."""
    models_dir = models_dir_beside(tmp_path / "user")
    sidecars: dict[str, bytes | str] = {
        s: EXAMPLE.with_name(EXAMPLE.stem + s).read_bytes() for s in (".depth.png", ".depth.json")
    }
    args = [
        f"image={example(tmp_path, sidecars)}",
        "fov=fixed",
        "detector=none",
        "segmentation=eyes",
        f"depth.onnx.models_dir={models_dir}",
        "run.until=estimate_depth",
    ]
    result = psdr_room([*args, f"hydra.run.dir={tmp_path / 'run'}"], cli_env)
    assert result.returncode == 0, result.stderr
    lines = warnings_in(result.stderr)
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"psdr-room: warning: {models_dir / 'depth_anything_v2_small.onnx'}: sha256 ")
    assert "expected afb6a5c28f3b…" in lines[0] and "depth=file" in result.stderr


# ------------------------------------------------------------------------------------------ the digest cache
def test_the_check_hashes_again_only_when_size_or_mtime_change(tmp_path: Path, cache_dir: Path) -> None:
    """Each check runs in a new process, as each run does: the digest comes from psdr-room's cache until the
    file's size or mtime_ns changes; nothing is written beside the network."""
    network = tmp_path / "mine" / "eyes.onnx"
    network.parent.mkdir()
    note = network.with_suffix(".json")

    def record(content: bytes) -> None:
        note.write_text(json.dumps({"sha256": hashlib.sha256(content).hexdigest()}))

    def check() -> subprocess.CompletedProcess[str]:
        code = (
            "import sys; from pathlib import Path; from psdr_room_core.method.checksums import check_beside; "
            "print(check_beside(Path(sys.argv[1]), 'restore it'))"
        )
        return subprocess.run([sys.executable, "-c", code, str(network)], capture_output=True, text=True, timeout=60)

    network.write_bytes(b"a" * 4096)
    record(b"a" * 4096)
    stat = network.stat()
    assert check().stdout.strip() == hashlib.sha256(b"a" * 4096).hexdigest()
    assert sorted(p.name for p in network.parent.iterdir()) == ["eyes.json", "eyes.onnx"]
    assert str(network) in json.loads((cache_dir / models.SHARED_HASH_CACHE).read_text())
    # other bytes, the same size and mtime: the remembered digest stands, so the file was not read again
    network.write_bytes(b"b" * 4096)
    os.utime(network, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert check().stdout.strip() == hashlib.sha256(b"a" * 4096).hexdigest()
    # a new mtime: hashed again, and refused
    os.utime(network, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    refused = check()
    assert refused.returncode != 0 and f"{network}: sha256 {hashlib.sha256(b'b' * 4096).hexdigest()[:12]}…" in (
        refused.stderr
    )
    # a new size at that mtime: hashed again
    network.write_bytes(b"c" * 5000)
    record(b"c" * 5000)
    os.utime(network, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    assert check().stdout.strip() == hashlib.sha256(b"c" * 5000).hexdigest()


# ------------------------------------------------------------------------------------------ downloads
CONTENT = bytes(range(256)) * 16384  # 4 MiB
SENT_BEFORE_STALLING = 2 << 20


@pytest.fixture
def stalling_server() -> Iterator[str]:
    """A local HTTP server of ``weights.bin`` (CONTENT) whose first answer stalls after 2 MiB (until the test
    ends, 60 s at most) and whose later answers are whole; yields its base URL."""
    released = threading.Event()
    answers = []

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            answers.append(self.path)
            self.send_response(200)
            self.send_header("Content-Length", str(len(CONTENT)))
            self.end_headers()
            if len(answers) == 1:
                self.wfile.write(CONTENT[:SENT_BEFORE_STALLING])
                self.wfile.flush()
                released.wait(60)
                return
            self.wfile.write(CONTENT)

        def log_message(self, *args: object) -> None:
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        released.set()
        httpd.shutdown()
        httpd.server_close()
        thread.join(5)


def registry_with(path: Path, url: str) -> Path:
    entry = {
        "name": "tiny",
        "capability": "depth",
        "family": "depth_anything_v2",
        "file": "tiny.onnx",
        "url": url,
        "size": len(CONTENT),
        "sha256": hashlib.sha256(CONTENT).hexdigest(),
        "licence": "MIT",
        "source": "https://example.org/tiny",
        "obtain": "copy it by hand",
    }
    path.write_text(json.dumps({"format": 1, "models": [entry]}))
    return path


def sweep_line(stderr: str, models_dir: Path) -> None:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0] == f"removed 1 unfinished download entry left in {models_dir} by a process that was stopped"


def test_a_killed_download_leaves_debris_the_next_download_sweeps(
    tmp_path: Path, stalling_server: str, cli_env: dict[str, str]
) -> None:
    registry = registry_with(tmp_path / "registry.json", f"{stalling_server}/weights.bin")
    models_dir = tmp_path / "models"
    command = [shutil.which(MODELS) or MODELS, "--registry", str(registry), "download", "tiny", "--quiet"]
    command += ["--models-dir", str(models_dir)]
    download = subprocess.Popen(command, env=cli_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not [p for p in models_dir.glob(".*.part") if p.stat().st_size >= 1 << 20]:
        assert download.poll() is None and time.monotonic() < deadline, download.communicate()
        time.sleep(0.05)
    download.send_signal(signal.SIGTERM)
    assert download.wait(30) == -signal.SIGTERM
    assert [p.name for p in models_dir.iterdir()]  # the killed writer's scratch file
    assert not (models_dir / "tiny.onnx").exists()
    again = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    sweep_line(again.stderr, models_dir)
    assert sorted(p.name for p in models_dir.iterdir()) == [models.HASH_CACHE, "tiny.onnx"]
    assert (models_dir / "tiny.onnx").read_bytes() == CONTENT


@pytest.mark.parametrize("command", ["list", "verify"])
def test_every_models_command_sweeps_a_stopped_downloads_leftovers(
    command: str, tmp_path: Path, cli_env: dict[str, str]
) -> None:
    models_dir = tmp_path / "models"
    models_dir.mkdir()
    (models_dir / "mine.onnx").write_text("the user's")
    leave = "import sys; from pathlib import Path; from psdr_room_core.engine.debris import scratch_file; "
    leave += "scratch_file(Path(sys.argv[1]), 'download', '.part')"
    subprocess.run([sys.executable, "-c", leave, str(models_dir)], check=True, timeout=60)  # its writer has ended
    assert len(list(models_dir.glob(".download-*.part"))) == 1
    result = psdr_room([command, "--models-dir", str(models_dir)], cli_env, MODELS)
    assert result.returncode == 0, result.stderr
    sweep_line(result.stderr, models_dir)
    assert [p.name for p in models_dir.iterdir()] == ["mine.onnx"]


def test_texture_weights_not_as_published_are_passed_over_or_refused(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from psdr_room_plugins.texture.vgg19 import Vgg19Descriptor

    entry = models.lookup("vgg19_imagenet", models.load_registry())
    (tmp_path / entry.file).write_bytes(b"not the published VGG19 state dict")
    descriptor = Vgg19Descriptor(models_dir=str(tmp_path))
    with caplog.at_level(logging.WARNING, logger="psdr_room"):
        reason = descriptor.unavailable()
    assert reason is not None and entry.file in reason and len(caplog.records) == 1
    with pytest.raises(checksums.Mismatch, match="psdr-room-models download vgg19_imagenet --force"):
        descriptor.weights  # noqa: B018 (the property loads the weights)
