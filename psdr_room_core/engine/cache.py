"""Content-addressed stage cache: keys from what a stage computes on, entries committed atomically.

A stage's key hashes its name, its function's and implementations' names, versions and code fingerprints
(:mod:`.fingerprint`), its resolved config, and the digests of its inputs (artifacts, and files it reads such as the photo). An entry is a
directory ``<root>/entries/<key[:2]>/<key>/`` with one sub-directory per output artifact and a
``manifest.json`` naming each output's kind and content digest. Entries are written into
``<root>/tmp/`` and renamed into place, so a reader sees a complete entry or none; a per-key file lock
lets concurrent processes (a multirun, or two users on a shared cache) compute each entry once.

A hit is verified before use: each output is re-hashed against its manifest digest. An entry whose files
changed on disk is logged in one line and moved aside to ``<root>/quarantine/`` (kept for inspection, never
trusted), and the stage recomputes. A commit that meets a full disk is one error naming the cache folder, its
partial entry removed. ``psdr-room-cache`` verifies, measures and prunes a cache.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import logging
import os
import shutil
import tempfile
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .artifacts import Artifact
from .debris import scratch_dir, sweep
from .errors import PsdrRoomError

log = logging.getLogger("psdr_room")

SCHEMA = 2
"""The format of keys and entries, part of every key: a new one recomputes every stage once. 2: code fingerprints
digest code, not docstrings and comments (:mod:`.fingerprint`)."""
CACHE_MODES = ("off", "read", "readwrite")


def default_cache_dir() -> Path:
    """``$PSDR_ROOM_CACHE_DIR`` or ``~/.cache/psdr-room``: the pipeline's default ``cache_dir``, and where the
    plugins keep their own caches (database index, thumbnails, CLIP embeddings)."""
    return Path(os.environ.get("PSDR_ROOM_CACHE_DIR") or Path.home() / ".cache" / "psdr-room")


def canonical_json(value: Any) -> str:
    """Deterministic JSON for hashing (sorted keys, no whitespace, tuples as lists)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)


def digest_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def digest_dir(directory: Path) -> str:
    """Digest of a directory's files: their relative paths and contents, in sorted order."""
    h = hashlib.sha256()
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        h.update(path.relative_to(directory).as_posix().encode() + b"\0")
        h.update(digest_file(path).encode())
    return h.hexdigest()


def stage_key(
    stage: str,
    function: str,
    function_version: str,
    function_code: str,
    config: Mapping[str, Any],
    implementations: Mapping[str, Mapping[str, Any]],
    inputs: Mapping[str, str],
    files: Mapping[str, str],
) -> str:
    """The cache key of one stage execution.

    ``function_code``: the fingerprint of the stage function's code (:mod:`.fingerprint`); ``implementations``
    maps capability → {name, version, code, params}; ``inputs`` maps input name → artifact digest; ``files``
    maps file role → content digest.
    """
    payload = {
        "schema": SCHEMA,
        "stage": stage,
        "function": [function, function_version, function_code],
        "config": config,
        "implementations": implementations,
        "inputs": inputs,
        "files": files,
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


@dataclass(frozen=True)
class Entry:
    """A committed cache entry."""

    key: str
    path: Path
    manifest: dict[str, Any]

    @property
    def digests(self) -> dict[str, str]:
        return {name: out["digest"] for name, out in self.manifest["outputs"].items()}

    def load(self, name: str, types: Mapping[str, type[Artifact]]) -> Artifact:
        """Output ``name``, read by its registered type (``types``: kind → class)."""
        kind = self.manifest["outputs"][name]["kind"]
        if kind not in types:
            raise PsdrRoomError(
                f"{self.path / name}: artifact kind '{kind}' is not registered by any installed plugin; "
                "reinstall the plugin that made it, or rerun with cache=off"
            )
        return types[kind].load(self.path / name)


def save_artifacts(outputs: Mapping[str, Artifact], directory: Path) -> dict[str, dict[str, str]]:
    """Save each output under ``directory/<name>/``; return {name: {kind, digest}}."""
    described = {}
    for name, artifact in outputs.items():
        target = directory / name
        target.mkdir(parents=True)
        artifact.save(target)
        described[name] = {"kind": artifact.kind, "digest": digest_dir(target)}
    return described


class Store:
    """The on-disk cache (see module docstring)."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root).expanduser()
        try:
            for sub in ("entries", "tmp", "locks"):
                (self.root / sub).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise PsdrRoomError(
                f"cache_dir={self.root}: cannot be created ({exc.strerror}); set cache_dir= to a writable directory"
            ) from None
        if self.writable():
            sweep(self.root / "tmp", "entry")  # entries a killed process left half-written

    def writable(self) -> bool:
        """Whether entries can be committed here (False for a read-only shared cache or file system)."""
        try:
            with tempfile.TemporaryFile(dir=self.root / "tmp"):
                return True
        except OSError:
            return False

    def _entry_path(self, key: str) -> Path:
        return self.root / "entries" / key[:2] / key

    def _read(self, key: str) -> Entry | None:
        path = self._entry_path(key)
        try:
            manifest = json.loads((path / "manifest.json").read_text())
        except FileNotFoundError:
            return None
        except (json.JSONDecodeError, UnicodeDecodeError):
            manifest = None
        return Entry(key=key, path=path, manifest=manifest if isinstance(manifest, dict) else {"outputs": None})

    def lookup(self, key: str) -> Entry | None:
        """The verified entry for ``key``; None when there is none, or it was damaged (then moved aside)."""
        entry = self._read(key)
        if entry is None:
            return None
        problem = damage(entry)
        if problem is None:
            return entry
        self.quarantine(entry, problem)
        return None

    def entries(self) -> Iterator[Entry]:
        """Every committed entry (unverified)."""
        for path in sorted((self.root / "entries").glob("*/*")):
            entry = self._read(path.name)
            if entry is not None:
                yield entry

    def quarantine(self, entry: Entry, problem: str) -> None:
        """Move a damaged entry aside to ``<root>/quarantine/`` (logged in one line); it is never served again."""
        target = self.root / "quarantine" / f"{entry.key}-{int(time.time())}"
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.rename(entry.path, target)
            where = f"moved to {target}"
        except OSError as exc:  # a read-only shared cache: not served, left in place
            where = f"left in place ({exc.strerror})"
        log.warning(
            "cache entry %s (%s) is damaged: %s; %s, recomputing",
            entry.key[:12],
            entry.manifest.get("stage", "?"),
            problem,
            where,
        )

    @contextlib.contextmanager
    def lock(self, key: str) -> Iterator[None]:
        """Hold an exclusive lock for ``key`` (released by the OS if the process dies)."""
        with open(self.root / "locks" / f"{key}.lock", "a") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    def commit(
        self,
        key: str,
        stage: str,
        outputs: Mapping[str, Artifact],
        seconds: float,
        replace: bool = False,
        timings: Mapping[str, float] | None = None,
    ) -> Entry:
        """Write ``outputs`` as the entry for ``key``, atomically; return the committed entry. An entry already
        there is kept (another process computed the same key: equal) unless ``replace``: a forced recompute
        (``run.only``, ``run.from``) supersedes the entry it recomputed. ``seconds`` and the stage's own
        ``timings`` go to the manifest, outside every digest."""
        tmp = scratch_dir(self.root / "tmp", "entry")
        try:
            described = save_artifacts(outputs, tmp)
            manifest = {
                "schema": SCHEMA,
                "key": key,
                "stage": stage,
                "outputs": described,
                "seconds": seconds,
                "timings": dict(timings or {}),
                "created": time.time(),
            }
            (tmp / "manifest.json").write_text(json.dumps(manifest, indent=2, sort_keys=True))
            final = self._entry_path(key)
            final.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.rename(tmp, final)
            except OSError:  # an entry is there
                if replace:
                    old = tmp.with_name(tmp.name + "-replaced")
                    os.rename(final, old)
                    os.rename(tmp, final)
                    shutil.rmtree(old, ignore_errors=True)
                else:
                    shutil.rmtree(tmp, ignore_errors=True)
        except OSError as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            if exc.errno != errno.ENOSPC:
                raise
            raise PsdrRoomError(
                f"{self.root}: no space left on device for the results of stage {stage}; free some space there "
                "or set cache_dir= to a folder on another disk"
            ) from None
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        entry = self._read(key)
        assert entry is not None
        return entry


def damage(entry: Entry) -> str | None:
    """What is wrong with an entry's files (an unreadable manifest, a missing output, an output whose digest
    differs from the manifest's), or None when they are as committed."""
    outputs = entry.manifest.get("outputs")
    if not isinstance(outputs, dict) or entry.manifest.get("schema") != SCHEMA:
        return "unreadable manifest.json"
    for name, described in outputs.items():
        directory = entry.path / name
        if not directory.is_dir():
            return f"output {name} is missing"
        if digest_dir(directory) != described.get("digest"):
            return f"output {name} changed on disk"
    return None
