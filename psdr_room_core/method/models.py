"""The registry of model files psdr-room can use, and how they are downloaded and checked.

Neural implementations (``depth=onnx``, ``segmentation=onnx``, CLIP retrieval, the VGG texture loss) read
weight files a user downloads once into the *models directory*: ``$PSDR_ROOM_MODELS_DIR``, else
``<user data dir>/psdr-room/models`` (``$XDG_DATA_HOME`` or ``~/.local/share`` on Linux and macOS,
``%LOCALAPPDATA%`` on Windows). Which files exist, where they come from, their licence and checksum are
data, not code: ``psdr_room_core/method/models.json`` for the built-in ones, plus any file a plugin returns
from the ``model_registries`` hook. An entry::

    {"name": "depth_anything_v2_small", "capability": "depth", "family": "depth_anything_v2",
     "file": "depth_anything_v2_small.onnx", "url": "https://...", "size": null, "sha256": "afb6...",
     "licence": "Apache-2.0", "source": "https://...", "obtain": "how to get it without this command"}

``url`` is null for files that must be exported by hand (``obtain`` gives the exact command); ``sha256``
and ``size`` are null where no checksum is published (such files are reported "unverified"), and
``sha256_prefix`` holds a published leading part of a checksum (torchvision file names).
:func:`download` streams into a scratch file of the models directory (kind ``download``:
:func:`psdr_room_core.engine.debris.scratch_file`), checks the size and checksum and renames the file into place:
a failed download leaves nothing behind, and a killed one leaves a scratch file that the next
``psdr-room-models`` command sweeps. Digests are remembered by (size, mtime_ns) (:func:`cached_sha256`), so that
listing and the check before every use (:mod:`.checksums`) do not re-hash big files. This module is used by the
``psdr-room-models`` command (:mod:`psdr_room_core.applications.models`) and by the implementations that read
model files; it does not import onnxruntime.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import re
import sys
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from psdr_room_core.engine.cache import default_cache_dir
from psdr_room_core.engine.debris import scratch_file
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole

from .capabilities import CAPABILITIES

if TYPE_CHECKING:
    from psdr_room_core.engine.plugins import PluginSystem

log = logging.getLogger(__name__)

USES = (*CAPABILITIES, "metric")
"""What a model file can serve: a capability, or a ``metric`` of the report (LPIPS)."""

BUILTIN_REGISTRY = Path(__file__).with_name("models.json")
MODELS_DIR_ENV = "PSDR_ROOM_MODELS_DIR"
HASH_CACHE = ".sha256-cache.json"
"""Digests of a models directory's files by (size, mtime_ns), kept in that directory (key: the file name)."""
SHARED_HASH_CACHE = "sha256-cache.json"
"""Digests of other files (networks shipped in the package or given by path) by (size, mtime_ns), kept in
psdr-room's cache directory (key: the absolute path), so that nothing is written beside them."""
_CHUNK = 1 << 20
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")
_HEX64 = re.compile(r"^[0-9a-f]{64}$")
_HEX_PREFIX = re.compile(r"^[0-9a-f]{8,63}$")


# ------------------------------------------------------------------------------------------ entries
@dataclass(frozen=True)
class ModelEntry:
    """One model file of the registry (see the module docstring for the JSON form)."""

    name: str
    capability: str
    family: str
    file: str
    licence: str
    source: str
    obtain: str
    url: str | None = None
    size: int | None = None
    sha256: str | None = None
    sha256_prefix: str | None = None
    approx_size: str | None = None
    checksum_source: str | None = None
    description: str = ""
    registry: str = ""
    """The registry file the entry was read from (not part of the JSON)."""

    def path(self, models_dir: Path) -> Path:
        """Where the file lives once installed."""
        return Path(models_dir) / self.file

    @property
    def checksum(self) -> str:
        """How the file is checked: the full sha256, its published prefix, or nothing."""
        return self.sha256 or (f"{self.sha256_prefix}…" if self.sha256_prefix else "")

    def size_text(self) -> str:
        if self.size is not None:
            return _human(self.size)
        return f"~{self.approx_size}" if self.approx_size else "?"


_REQUIRED = ("name", "capability", "family", "file", "licence", "source", "obtain")
_OPTIONAL = tuple(f.name for f in fields(ModelEntry) if f.name not in _REQUIRED and f.name != "registry")


def _check_entry(raw: Any, where: Path, index: int) -> ModelEntry:
    label = f"{where}: models[{index}]"
    if not isinstance(raw, dict):
        raise PsdrRoomError(f'{label} is not a JSON object; each model is {{"name": ..., "file": ..., ...}}')
    name = raw.get("name")
    if isinstance(name, str):
        label = f"{where}: model '{name}'"
    missing = [k for k in _REQUIRED if k not in raw]
    if missing:
        raise PsdrRoomError(f"{label} lacks {', '.join(missing)}; every model needs {', '.join(_REQUIRED)}")
    unknown = sorted(set(raw) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise PsdrRoomError(f"{label}: unknown key(s) {', '.join(unknown)}; known: {', '.join(_REQUIRED + _OPTIONAL)}")
    for key in _REQUIRED + ("url", "sha256", "sha256_prefix", "approx_size", "checksum_source", "description"):
        value = raw.get(key)
        if value is not None and not isinstance(value, str):
            raise PsdrRoomError(f"{label}: '{key}' must be a string, got {value!r}; fix the registry file")
    if not _NAME.match(raw["name"]):
        raise PsdrRoomError(f"{label}: name must be letters, digits, '_', '.' or '-'; rename it")
    if raw["capability"] not in USES:
        raise PsdrRoomError(f"{label}: unknown capability '{raw['capability']}'; use one of {', '.join(USES)}")
    if not _NAME.match(raw["file"]) or raw["file"].startswith("."):
        raise PsdrRoomError(f"{label}: file must be a plain file name (no directory, not hidden), got {raw['file']!r}")
    size = raw.get("size")
    if size is not None and (isinstance(size, bool) or not isinstance(size, int) or size <= 0):
        raise PsdrRoomError(f"{label}: size must be a positive number of bytes or null, got {size!r}")
    sha = raw.get("sha256")
    if sha is not None and not _HEX64.match(sha):
        raise PsdrRoomError(f"{label}: sha256 must be 64 lower-case hex digits or null, got {sha!r}")
    prefix = raw.get("sha256_prefix")
    if prefix is not None and not _HEX_PREFIX.match(prefix):
        raise PsdrRoomError(f"{label}: sha256_prefix must be 8 to 63 lower-case hex digits or null, got {prefix!r}")
    url = raw.get("url")
    if url is not None and urllib.parse.urlsplit(url).scheme not in ("http", "https"):
        raise PsdrRoomError(f"{label}: url must be http(s) or null, got {url!r}")
    values = dict(raw)
    values["description"] = values.get("description") or ""
    return ModelEntry(**values, registry=str(where))


def read_registry_file(path: Path) -> list[ModelEntry]:
    """The entries of one registry JSON file (``{"format": 1, "models": [...]}``), checked."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: model registry not found; fix the path (or the plugin returning it)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PsdrRoomError(f"{path}: cannot read the model registry ({exc}); check the file") from None
    except json.JSONDecodeError as exc:
        raise PsdrRoomError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg}); fix the model registry") from None
    if not isinstance(data, dict) or data.get("format") != 1 or not isinstance(data.get("models"), list):
        raise PsdrRoomError(f'{path}: not a psdr-room model registry; expected {{"format": 1, "models": [...]}}')
    return [_check_entry(raw, path, i) for i, raw in enumerate(data["models"])]


def registry_files(system: PluginSystem | None = None) -> list[Path]:
    """The built-in registry followed by the files plugins return from ``model_registries``."""
    if system is None:
        from psdr_room_core.engine.plugins import plugin_system

        system = plugin_system()
    files = [BUILTIN_REGISTRY]
    for result in system.hook.model_registries():
        if isinstance(result, (str, os.PathLike)):
            result = [result]
        files.extend(Path(p) for p in result or ())
    return files


def load_registry(files: Iterable[Path] | None = None) -> dict[str, ModelEntry]:
    """All model entries by name, from ``files`` (default: :func:`registry_files`), first file first.

    A name listed twice keeps its first entry; the second is reported in a warning and left out.
    """
    entries: dict[str, ModelEntry] = {}
    for path in registry_files() if files is None else files:
        for entry in read_registry_file(Path(path)):
            if entry.name in entries:
                log.warning(
                    "psdr-room: model '%s' of %s is already listed by %s; left out",
                    entry.name,
                    path,
                    entries[entry.name].registry,
                )
                continue
            entries[entry.name] = entry
    return entries


def lookup(name: str, registry: Mapping[str, ModelEntry], capability: str | None = None) -> ModelEntry:
    """The entry called ``name`` (of ``capability`` when given), or a one-line error listing the choices."""
    entry = registry.get(name)
    if entry is None or (capability is not None and entry.capability != capability):
        choices = sorted(n for n, e in registry.items() if capability is None or e.capability == capability)
        what = f"{capability} model" if capability else "model"
        found = f" ('{name}' is a {entry.capability} model)" if entry is not None else ""
        raise PsdrRoomError(
            f"unknown {what} '{name}'{found}; known: {', '.join(choices) or '(none)'} "
            "(psdr-room-models list shows them)"
        )
    return entry


# ------------------------------------------------------------------------------------- models dir
def user_data_dir() -> Path:
    """The per-user data directory: ``%LOCALAPPDATA%`` on Windows, else ``$XDG_DATA_HOME`` or
    ``~/.local/share`` (the same rule as the ``models_dir`` default in ``conf/*/onnx.yaml``)."""
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        return Path(os.environ["LOCALAPPDATA"])
    return Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")


def default_models_dir() -> Path:
    """``$PSDR_ROOM_MODELS_DIR``, else ``<user data dir>/psdr-room/models``."""
    return Path(os.environ.get(MODELS_DIR_ENV) or user_data_dir() / "psdr-room" / "models").expanduser()


def resolve_models_dir(models_dir: str | os.PathLike | None) -> Path:
    """``models_dir`` as given (``~`` expanded), or the default when it is None or empty."""
    return Path(models_dir).expanduser() if models_dir else default_models_dir()


# ---------------------------------------------------------------------------------------- checking
def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


_DIGESTS: dict[tuple[str, int, int], str] = {}
"""This process's digests by (absolute path, size, mtime_ns): hashed once per process even where no cache file
can be written."""


def _hash_cache(path: Path, in_models_dir: bool) -> tuple[Path, str]:
    """The cache file remembering the digest of ``path``, and its key there."""
    if in_models_dir:
        return path.parent / HASH_CACHE, path.name
    return default_cache_dir() / SHARED_HASH_CACHE, str(path.absolute())


def _read_hash_cache(cache_file: Path) -> dict[str, Any]:
    try:
        cache = json.loads(cache_file.read_text())
    except (OSError, ValueError):
        return {}
    return cache if isinstance(cache, dict) else {}


def remember_sha256(path: Path, digest: str, *, in_models_dir: bool = False) -> None:
    """Record ``digest`` for ``path`` as it is now (size, mtime_ns): in this process, and in the cache file
    (:func:`cached_sha256`) where it can be written."""
    stat = path.stat()
    _DIGESTS[(str(path.absolute()), stat.st_size, stat.st_mtime_ns)] = digest
    cache_file, key = _hash_cache(path, in_models_dir)
    cache = _read_hash_cache(cache_file)
    cache[key] = [stat.st_size, stat.st_mtime_ns, digest]
    with contextlib.suppress(OSError):  # a read-only folder: this process remembers it, the next hashes again
        write_whole(cache_file, json.dumps(cache, indent=1, sort_keys=True))


def cached_sha256(path: Path, *, in_models_dir: bool = False) -> str:
    """sha256 of ``path``, hashed again only when its size or mtime_ns changed since it was remembered: in this
    process, and in :data:`HASH_CACHE` of the models directory for a file of it (``in_models_dir``), else in
    :data:`SHARED_HASH_CACHE` of psdr-room's cache directory (``$PSDR_ROOM_CACHE_DIR``, else
    ``~/.cache/psdr-room``)."""
    stat = path.stat()
    as_now = (str(path.absolute()), stat.st_size, stat.st_mtime_ns)
    if as_now in _DIGESTS:
        return _DIGESTS[as_now]
    cache_file, key = _hash_cache(path, in_models_dir)
    hit = _read_hash_cache(cache_file).get(key)
    if (
        isinstance(hit, list)
        and len(hit) == 3
        and hit[:2] == [stat.st_size, stat.st_mtime_ns]
        and isinstance(hit[2], str)
        and _HEX64.match(hit[2])
    ):
        _DIGESTS[as_now] = hit[2]
        return hit[2]
    digest = sha256_of(path)
    remember_sha256(path, digest, in_models_dir=in_models_dir)
    return digest


@dataclass(frozen=True)
class FileStatus:
    """The state of one model's file in a models directory."""

    entry: ModelEntry
    path: Path
    state: str
    """``installed`` (checksum matches), ``unverified`` (present, no published checksum), ``missing`` or
    ``corrupt`` (size or checksum differs)."""
    detail: str = ""

    @property
    def ok(self) -> bool:
        return self.state in ("installed", "unverified")

    def describe(self) -> str:
        text = {
            "installed": "installed (sha256 ok)",
            "unverified": "installed, unverified (no published checksum)",
            "missing": "missing",
            "corrupt": "corrupt",
        }[self.state]
        if self.state == "installed" and self.entry.sha256 is None:
            text = "installed (sha256 prefix ok)"
        return f"{text}: {self.detail}" if self.detail else text


def check_file(entry: ModelEntry, models_dir: Path, *, use_cache: bool = True) -> FileStatus:
    """Compare the installed file (if any) with the entry's size and checksum."""
    path = entry.path(models_dir)
    if not path.is_file():
        return FileStatus(entry, path, "missing")
    size = path.stat().st_size
    if entry.size is not None and size != entry.size:
        return FileStatus(entry, path, "corrupt", f"{size} bytes, expected {entry.size}")
    if not entry.sha256 and not entry.sha256_prefix:
        return FileStatus(entry, path, "unverified")
    if use_cache:
        digest = cached_sha256(path, in_models_dir=True)
    else:
        digest = sha256_of(path)
        remember_sha256(path, digest, in_models_dir=True)
    if not _checksum_matches(entry, digest):
        return FileStatus(entry, path, "corrupt", f"sha256 {digest[:12]}…, expected {entry.checksum[:12].rstrip('…')}…")
    return FileStatus(entry, path, "installed")


def _checksum_matches(entry: ModelEntry, digest: str) -> bool:
    if entry.sha256:
        return digest == entry.sha256
    if entry.sha256_prefix:
        return digest.startswith(entry.sha256_prefix)
    return True


def verify(models_dir: Path, registry: Mapping[str, ModelEntry], names: Sequence[str] = ()) -> list[FileStatus]:
    """Check the named models (default: all) in ``models_dir``, hashing every present file afresh."""
    entries = [lookup(n, registry) for n in names] if names else list(registry.values())
    return [check_file(e, Path(models_dir), use_cache=False) for e in entries]


def require(entry: ModelEntry, models_dir: Path) -> Path:
    """The installed file of ``entry``, or a one-line error naming it and the command that gets it.

    Only presence is checked here; :func:`.checksums.check_installed` checks the content before use.
    """
    path = entry.path(models_dir)
    if not path.is_file():
        how = (
            f"run `psdr-room-models download {entry.name}`"
            if entry.url
            else f"export it as `psdr-room-models info {entry.name}` explains"
        )
        raise PsdrRoomError(
            f"{path}: model file of '{entry.name}' not found; {how}, "
            f"or set models_dir to the directory that holds {entry.file}"
        )
    return path


# -------------------------------------------------------------------------------------- download
def download(
    name: str,
    models_dir: Path,
    registry: Mapping[str, ModelEntry] | None = None,
    *,
    progress: bool = True,
    timeout: float = 30.0,
    force: bool = False,
) -> Path:
    """Download model ``name`` into ``models_dir`` and return its path.

    The file is streamed into a scratch file beside its final name (see the module docstring), its size and
    checksum are checked (when published), and it is renamed into place; on any failure the scratch file is
    removed and a :class:`PsdrRoomError` with one line says why and how to get the file by hand. A file already
    there is kept unless ``force`` when its checksum matches, or when none is published (``unverified``).
    """
    registry = load_registry() if registry is None else registry
    entry = lookup(name, registry)
    models_dir = Path(models_dir)
    target = entry.path(models_dir)
    if not entry.url:
        raise PsdrRoomError(f"{entry.file}: '{entry.name}' has no download URL; {entry.obtain}")
    if not force and check_file(entry, models_dir).state in ("installed", "unverified"):
        return target  # unverified: present, and nothing to check it against (--force fetches it again)
    created = not models_dir.exists()
    try:
        models_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PsdrRoomError(
            f"{models_dir}: cannot create the models directory ({exc.strerror or exc}); "
            f"choose another with --models-dir or ${MODELS_DIR_ENV}"
        ) from None
    host = urllib.parse.urlsplit(entry.url).hostname or entry.url
    fd, tmp = scratch_file(models_dir, "download", ".part")
    done = False
    try:
        try:
            with os.fdopen(fd, "wb") as out:
                digest, size = _fetch(entry, host, models_dir, out, progress=progress, timeout=timeout)
                out.flush()
                os.fsync(out.fileno())
        except OSError as exc:  # network errors are PsdrRoomErrors by now: this is the disk
            raise PsdrRoomError(
                f"{models_dir}: cannot write {entry.file} ({exc.strerror or exc}); free some "
                "space or choose another directory with --models-dir"
            ) from None
        if entry.size is not None and size != entry.size:
            raise PsdrRoomError(
                f"{entry.url}: downloaded {size} bytes, expected {entry.size}; nothing was saved "
                f"in {models_dir}; try again, or get {entry.file} by hand ({entry.source})"
            )
        if not _checksum_matches(entry, digest):
            raise PsdrRoomError(
                f"{entry.url}: sha256 of the download is {digest}, expected {entry.checksum}; "
                f"nothing was saved in {models_dir}; try again, and if it persists the file "
                f"changed upstream: check {entry.source}"
            )
        os.replace(tmp, target)
        done = True
        remember_sha256(target, digest, in_models_dir=True)
    finally:
        if not done:
            tmp.unlink(missing_ok=True)
            if created:
                with contextlib.suppress(OSError):
                    models_dir.rmdir()  # only if still empty: leave no trace of a failed first download
    return target


def _fetch(
    entry: ModelEntry, host: str, models_dir: Path, out: Any, *, progress: bool, timeout: float
) -> tuple[str, int]:
    """Stream ``entry.url`` into ``out``; returns (sha256 hex, bytes)."""
    from tqdm import tqdm

    by_hand = (
        f"download it on a connected machine ({entry.url}) and put it in {models_dir} as {entry.file}, "
        "then `psdr-room-models verify`"
    )
    assert entry.url is not None  # download() refuses an entry without one
    request = urllib.request.Request(entry.url, headers={"User-Agent": "psdr-room-models"})
    digest = hashlib.sha256()
    size = 0
    try:
        with urllib.request.urlopen(request, timeout=timeout) as response:
            length = response.headers.get("Content-Length")
            total = int(length) if length and length.isdigit() else entry.size
            with tqdm(
                total=total,
                unit="B",
                unit_scale=True,
                unit_divisor=1024,
                desc=entry.file,
                disable=not progress,
                leave=False,
                file=sys.stderr,
            ) as bar:
                while chunk := response.read(_CHUNK):
                    out.write(chunk)
                    digest.update(chunk)
                    size += len(chunk)
                    bar.update(len(chunk))
    except urllib.error.HTTPError as exc:
        raise PsdrRoomError(
            f"{host} answered HTTP {exc.code} ({exc.reason}) for {entry.file}; the URL may have moved: {by_hand}"
        ) from None
    except urllib.error.URLError as exc:
        reason = exc.reason.strerror if isinstance(exc.reason, OSError) and exc.reason.strerror else exc.reason
        raise PsdrRoomError(f"cannot reach {host} to download {entry.file}: {reason}; {by_hand}") from None
    except (TimeoutError, ConnectionError) as exc:
        raise PsdrRoomError(
            f"cannot reach {host} to download {entry.file}: {exc or type(exc).__name__}; {by_hand}"
        ) from None
    if length and length.isdigit() and size != int(length):
        raise PsdrRoomError(
            f"cannot reach {host} to download {entry.file}: the connection closed after "
            f"{size} of {length} bytes; {by_hand}"
        )
    return digest.hexdigest(), size


# ------------------------------------------------------------------------------------------ helpers
def _human(size: int) -> str:
    value = float(size)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{size} B"
