"""The model registry, downloads and ``psdr-room-models``: offline listing, a real local HTTP server for
downloads and checksum mismatches, a closed local port for the offline failure, verification, plugins'
registries. Nothing here reaches beyond 127.0.0.1."""

from __future__ import annotations

import hashlib
import http.server
import json
import threading
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from psdr_room_core.applications import models as models_cli
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import load_plugins
from psdr_room_core.engine.registry import Origin
from psdr_room_core.method import models
from psdr_room_core.method.models import USES

CONTENT = b"tiny model weights\n" * 4096
SHA = hashlib.sha256(CONTENT).hexdigest()
CLOSED_PORT = "http://127.0.0.1:9/weights.bin"  # the discard port: nothing listens, the connection is refused


# ======================================================================================= fixtures
@pytest.fixture
def server(tmp_path: Path) -> Iterator[str]:
    """A local HTTP server serving ``weights.bin`` (CONTENT); yields its base URL."""
    root = tmp_path / "served"
    root.mkdir()
    (root / "weights.bin").write_bytes(CONTENT)

    class Handler(http.server.SimpleHTTPRequestHandler):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, directory=str(root), **kwargs)

        def log_message(self, *args):  # keep pytest output clean
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()
        thread.join(5)


@pytest.fixture
def no_network(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args, **kwargs):
        raise AssertionError("this command must not use the network")

    monkeypatch.setattr(urllib.request, "urlopen", refuse)


def entry(name: str = "tiny", url: str | None = None, **overrides) -> dict:
    data = {
        "name": name,
        "capability": "depth",
        "family": "depth_anything_v2",
        "file": f"{name}.onnx",
        "url": url,
        "size": len(CONTENT),
        "sha256": SHA,
        "licence": "MIT",
        "source": "https://example.org/tiny",
        "obtain": "copy it by hand",
    }
    data.update(overrides)
    return data


def registry_file(path: Path, *entries: dict) -> Path:
    path.write_text(json.dumps({"format": 1, "models": list(entries)}))
    return path


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir()) if directory.exists() else []


# ======================================================================================= registry
def test_builtin_registry_is_complete_and_well_formed() -> None:
    registry = models.load_registry([models.BUILTIN_REGISTRY])
    by_family = {e.family: e for e in registry.values()}
    for family in ("depth_anything_v2", "segformer_ade20k", "mask2former_ade20k", "clip_vit_b32_image", "vgg19"):
        assert family in by_family, family
    assert {e.capability for e in registry.values()} >= {"depth", "segmentation", "retrieval", "texture"}
    for e in registry.values():
        assert e.capability in USES and e.licence and e.source.startswith("https://") and e.obtain
        assert e.url is None or e.url.startswith("https://")
        assert e.url or "export" in e.obtain.lower() or "python" in e.obtain  # how to get it by hand
        if e.sha256:
            assert e.checksum_source, f"{e.name}: a checksum needs the public source it was read from"
    files = [e.file for e in registry.values()]
    assert len(files) == len(set(files))


def test_registry_file_errors_are_one_line_naming_the_file(tmp_path: Path) -> None:
    cases = {
        "bad_sha.json": entry(sha256="abc"),
        "unknown_key.json": entry(sha265=SHA),
        "bad_capability.json": entry(capability="deepth"),
        "path_as_file.json": entry(file="../escape.onnx"),
        "no_licence.json": {k: v for k, v in entry().items() if k != "licence"},
        "ftp.json": entry(url="ftp://example.org/x"),
    }
    for name, bad in cases.items():
        path = registry_file(tmp_path / name, bad)
        with pytest.raises(PsdrRoomError) as excinfo:
            models.load_registry([path])
        assert "\n" not in str(excinfo.value) and str(path) in str(excinfo.value), str(excinfo.value)
    (tmp_path / "broken.json").write_text("{ not json")
    with pytest.raises(PsdrRoomError, match=r"broken\.json: not valid JSON"):
        models.load_registry([tmp_path / "broken.json"])


def test_plugins_add_registries_through_the_hook(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    extra = registry_file(
        tmp_path / "plugin_models.json", entry("plugin_depth"), entry("depth_anything_v2_small", file="shadow.onnx")
    )

    class ToyPlugin:
        @hookimpl
        def model_registries(self) -> list[Path]:
            return [extra]

    system = load_plugins(extra=[(ToyPlugin(), Origin("toy_models", "tests", "toy_models (test)"))])
    files = models.registry_files(system)
    assert files[0] == models.BUILTIN_REGISTRY and extra in files
    registry = models.load_registry(files)
    assert registry["plugin_depth"].registry == str(extra)
    assert registry["depth_anything_v2_small"].file == "depth_anything_v2_small.onnx"  # built-in wins
    assert "already listed" in caplog.text


def test_models_dir_defaults(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv(models.MODELS_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert models.default_models_dir() == tmp_path / "data" / "psdr-room" / "models"
    monkeypatch.setenv(models.MODELS_DIR_ENV, str(tmp_path / "elsewhere"))
    assert models.default_models_dir() == tmp_path / "elsewhere"
    assert models.resolve_models_dir(None) == tmp_path / "elsewhere"
    assert models.resolve_models_dir(str(tmp_path / "given")) == tmp_path / "given"


# ======================================================================================= download
def test_download_from_a_local_server(tmp_path: Path, server: str) -> None:
    registry = models.load_registry([registry_file(tmp_path / "r.json", entry(url=f"{server}/weights.bin"))])
    target = models.download("tiny", tmp_path / "models", registry, progress=False)
    assert target == tmp_path / "models" / "tiny.onnx" and target.read_bytes() == CONTENT
    assert leftovers(tmp_path / "models") == [models.HASH_CACHE, "tiny.onnx"]  # no temporary file left
    assert models.check_file(registry["tiny"], tmp_path / "models").state == "installed"
    (tmp_path / "served" / "weights.bin").unlink()  # installed and verified: not fetched again
    assert models.download("tiny", tmp_path / "models", registry, progress=False) == target


def test_present_unverified_file_is_kept_unless_forced(tmp_path: Path, server: str) -> None:
    registry = models.load_registry(
        [registry_file(tmp_path / "r.json", entry(url=f"{server}/weights.bin", sha256=None, size=None))]
    )
    (tmp_path / "tiny.onnx").write_bytes(b"copied by hand")
    assert models.download("tiny", tmp_path, registry, progress=False).read_bytes() == b"copied by hand"
    assert models.download("tiny", tmp_path, registry, progress=False, force=True).read_bytes() == CONTENT


def test_checksum_mismatch_saves_nothing(tmp_path: Path, server: str) -> None:
    wrong = "0" * 64
    registry = models.load_registry(
        [registry_file(tmp_path / "r.json", entry(url=f"{server}/weights.bin", sha256=wrong))]
    )
    models_dir = tmp_path / "models"
    models_dir.mkdir()
    with pytest.raises(PsdrRoomError) as excinfo:
        models.download("tiny", models_dir, registry, progress=False)
    msg = str(excinfo.value)
    assert "\n" not in msg and f"{server}/weights.bin" in msg and SHA in msg and wrong in msg, msg
    assert "nothing was saved" in msg
    assert leftovers(models_dir) == []


def test_size_mismatch_and_http_errors(tmp_path: Path, server: str) -> None:
    registry = models.load_registry(
        [
            registry_file(
                tmp_path / "r.json",
                entry("sized", url=f"{server}/weights.bin", size=len(CONTENT) + 1, sha256=None),
                entry("gone", url=f"{server}/moved.bin"),
            )
        ]
    )
    with pytest.raises(PsdrRoomError, match="expected"):
        models.download("sized", tmp_path / "models", registry, progress=False)
    with pytest.raises(PsdrRoomError) as excinfo:
        models.download("gone", tmp_path / "models", registry, progress=False)
    assert "HTTP 404" in str(excinfo.value) and "gone.onnx" in str(excinfo.value)
    assert not (tmp_path / "models").exists()  # a failed first download leaves no directory either


def test_offline_download_fails_in_one_line_leaving_nothing(tmp_path: Path) -> None:
    registry = models.load_registry([registry_file(tmp_path / "r.json", entry(url=CLOSED_PORT))])
    models_dir = tmp_path / "models"
    with pytest.raises(PsdrRoomError) as excinfo:
        models.download("tiny", models_dir, registry, progress=False, timeout=5)
    msg = str(excinfo.value)
    assert "\n" not in msg
    assert msg.startswith("cannot reach 127.0.0.1 to download tiny.onnx:"), msg
    assert CLOSED_PORT in msg and str(models_dir) in msg and "psdr-room-models verify" in msg
    assert not models_dir.exists()
    models_dir.mkdir()
    with pytest.raises(PsdrRoomError):
        models.download("tiny", models_dir, registry, progress=False, timeout=5)
    assert leftovers(models_dir) == []


def test_require_names_the_file_and_the_command(tmp_path: Path) -> None:
    registry = models.load_registry([models.BUILTIN_REGISTRY])
    with pytest.raises(PsdrRoomError) as excinfo:
        models.require(registry["clip_vit_b32_image"], tmp_path)
    msg = str(excinfo.value)
    assert str(tmp_path / "clip_vit_b32_image.onnx") in msg and "psdr-room-models download clip_vit_b32_image" in msg
    (tmp_path / "clip_vit_b32_image.onnx").write_bytes(b"x")
    assert models.require(registry["clip_vit_b32_image"], tmp_path) == tmp_path / "clip_vit_b32_image.onnx"


def test_download_without_url_explains_the_export(tmp_path: Path) -> None:
    with pytest.raises(PsdrRoomError, match="has no download URL.*python"):
        models.download("mask2former_swin_tiny_ade_semantic", tmp_path, models.load_registry([models.BUILTIN_REGISTRY]))
    assert leftovers(tmp_path) == []


# ============================================================================================ CLI
def test_list_runs_offline_and_shows_every_model(tmp_path: Path, capsys: pytest.CaptureFixture, no_network) -> None:
    assert models_cli.main(["list", "--models-dir", str(tmp_path / "none")]) == 0
    out = capsys.readouterr().out
    for e in models.load_registry().values():
        assert e.name in out and e.file in out and e.licence in out
    assert "afb6a5c28f3b" in out and "missing" in out and "(does not exist yet)" in out
    for column in ("capability", "name", "file", "size", "sha256", "licence", "status", "source"):
        assert column in out.splitlines()[1]


def test_list_and_verify_report_installed_corrupt_unverified(
    tmp_path: Path, capsys: pytest.CaptureFixture, no_network
) -> None:
    reg = registry_file(tmp_path / "r.json", entry("good"), entry("bad"), entry("loose", sha256=None, size=None))
    models_dir = tmp_path / "models"
    models_dir.mkdir()
    (models_dir / "good.onnx").write_bytes(CONTENT)
    (models_dir / "bad.onnx").write_bytes(CONTENT[:-1] + b"!")
    (models_dir / "loose.onnx").write_bytes(b"whatever")
    args = ["--registry", str(reg)]
    assert models_cli.main([*args, "list", "--models-dir", str(models_dir), "--capability", "depth"]) == 0
    rows = {line.split()[1]: line for line in capsys.readouterr().out.splitlines()[2:]}
    assert "installed" in rows["good"] and "corrupt" in rows["bad"] and "unverified" in rows["loose"]
    assert "missing" in rows["depth_anything_v2_small"]
    assert models_cli.main([*args, "verify", "good", "loose", "--models-dir", str(models_dir)]) == 0
    out = capsys.readouterr().out
    assert "good: installed (sha256 ok)" in out and "loose: installed, unverified (no published checksum)" in out
    assert models_cli.main([*args, "verify", "--models-dir", str(models_dir)]) == 1  # bad.onnx is corrupt
    captured = capsys.readouterr()
    assert "bad: corrupt: sha256" in captured.out and "download bad --force" in captured.err
    assert models_cli.main([*args, "verify", "depth_anything_v2_small", "--models-dir", str(models_dir)]) == 1


def test_cli_download_local_and_offline(tmp_path: Path, server: str, capsys: pytest.CaptureFixture) -> None:
    reg = registry_file(tmp_path / "r.json", entry(url=f"{server}/weights.bin"), entry("offline", url=CLOSED_PORT))
    models_dir = tmp_path / "models"
    assert (
        models_cli.main(["--registry", str(reg), "download", "tiny", "--quiet", "--models-dir", str(models_dir)]) == 0
    )
    assert "tiny: " in capsys.readouterr().out and (models_dir / "tiny.onnx").read_bytes() == CONTENT
    assert (
        models_cli.main(["--registry", str(reg), "download", "offline", "--quiet", "--models-dir", str(models_dir)])
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("psdr-room-models: error: cannot reach 127.0.0.1"), err
    assert leftovers(models_dir) == [models.HASH_CACHE, "tiny.onnx"]
    assert models_cli.main(["--registry", str(reg), "download", "tiny", "typo", "--models-dir", str(models_dir)]) == 2
    assert "unknown model 'typo'" in capsys.readouterr().err


def test_info_shows_how_to_obtain(capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    assert models_cli.main(["info", "mask2former_swin_tiny_ade_semantic", "--models-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "torch.onnx.export" in out and "facebook/mask2former-swin-tiny-ade-semantic" in out
    assert "none (export by hand)" in out
