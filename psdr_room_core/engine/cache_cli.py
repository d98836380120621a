"""``psdr-room-cache``: look after a stage cache.

    psdr-room-cache du                       # size and entries per stage
    psdr-room-cache verify                   # re-hash every entry; damaged ones are moved to quarantine/
    psdr-room-cache prune --older-than 30    # remove entries not used for 30 days ...
    psdr-room-cache prune --max-size 5       # ... or the least recently used until the cache is under 5 GB

The cache is ``--cache-dir`` (default: ``$PSDR_ROOM_CACHE_DIR``, else ``~/.cache/psdr-room``, as the pipeline's
``cache_dir``). ``prune`` also empties ``quarantine/``. An entry's last use is its manifest's access time,
which every hit reads.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from collections import defaultdict
from pathlib import Path

from .cache import Entry, Store, damage, default_cache_dir
from .errors import PsdrRoomError


def size_of(path: Path) -> int:
    """Bytes of the files under ``path``."""
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink())


def last_used(entry: Entry) -> float:
    """When the entry was last read or written (the manifest's access or modification time, the later)."""
    stat = (entry.path / "manifest.json").stat()
    return max(stat.st_atime, stat.st_mtime)


def usage(store: Store) -> str:
    """A table of entries and bytes per stage."""
    per_stage: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for entry in store.entries():
        row = per_stage[str(entry.manifest.get("stage", "?"))]
        row[0] += 1
        row[1] += size_of(entry.path)
    quarantined = size_of(store.root / "quarantine") if (store.root / "quarantine").is_dir() else 0
    lines = [f"{'stage':<20} {'entries':>8} {'MB':>10}"]
    for stage, (count, size) in sorted(per_stage.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"{stage:<20} {count:>8} {size / 1e6:>10.1f}")
    total = sum(r[1] for r in per_stage.values())
    lines.append(f"{'total':<20} {sum(r[0] for r in per_stage.values()):>8} {total / 1e6:>10.1f}")
    lines.append(f"{'quarantine':<20} {'':>8} {quarantined / 1e6:>10.1f}")
    return "\n".join(lines)


def verify(store: Store) -> tuple[int, list[str]]:
    """Re-hash every entry; move damaged ones aside. Returns (entries checked, one line per damaged one)."""
    checked, damaged = 0, []
    for entry in store.entries():
        checked += 1
        problem = damage(entry)
        if problem is not None:
            store.quarantine(entry, problem)
            damaged.append(f"{entry.key[:12]} ({entry.manifest.get('stage', '?')}): {problem}")
    return checked, damaged


def prune(store: Store, older_than_days: float | None, max_size_gb: float | None) -> tuple[int, int]:
    """Remove entries unused for ``older_than_days``, then the least recently used until the cache holds at
    most ``max_size_gb``; empty the quarantine. Returns (entries removed, bytes freed)."""
    entries = sorted(store.entries(), key=last_used)
    sizes = {e.key: size_of(e.path) for e in entries}
    total = sum(sizes.values())
    removed, freed = 0, 0
    now = time.time()
    for entry in entries:
        too_old = older_than_days is not None and now - last_used(entry) > older_than_days * 86400
        too_big = max_size_gb is not None and total - freed > max_size_gb * 1e9
        if not (too_old or too_big):
            continue
        shutil.rmtree(entry.path, ignore_errors=True)
        removed += 1
        freed += sizes[entry.key]
    quarantine = store.root / "quarantine"
    if quarantine.is_dir():
        freed += size_of(quarantine)
        shutil.rmtree(quarantine, ignore_errors=True)
    return removed, freed


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``psdr-room-cache``."""
    parser = argparse.ArgumentParser(
        prog="psdr-room-cache",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("command", choices=("du", "verify", "prune"))
    parser.add_argument("--cache-dir", type=Path, default=None, help="the cache (default: the pipeline's)")
    parser.add_argument(
        "--older-than", type=float, default=None, metavar="DAYS", help="prune: entries unused this long"
    )
    parser.add_argument("--max-size", type=float, default=None, metavar="GB", help="prune: down to this size")
    args = parser.parse_args(argv)
    root = (args.cache_dir or default_cache_dir()).expanduser()
    try:
        if not (root / "entries").is_dir():
            raise PsdrRoomError(
                f"--cache-dir {root}: not a psdr-room cache (no entries/ folder); pass the cache_dir of your runs"
            )
        store = Store(root)
        if args.command == "du":
            print(usage(store))
        elif args.command == "verify":
            start = time.perf_counter()
            checked, damaged = verify(store)
            for line in damaged:
                print(f"damaged: {line}")
            print(
                f"{checked} entries checked in {time.perf_counter() - start:.2f} s, {len(damaged)} damaged"
                + (f" (moved to {root / 'quarantine'})" if damaged else "")
            )
            return 1 if damaged else 0
        else:
            if args.older_than is None and args.max_size is None:
                raise PsdrRoomError("prune: give --older-than DAYS and/or --max-size GB")
            if any(v is not None and v < 0 for v in (args.older_than, args.max_size)):
                raise PsdrRoomError("prune: --older-than and --max-size must be 0 or more")
            removed, freed = prune(store, args.older_than, args.max_size)
            print(f"removed {removed} entries, freed {freed / 1e6:.1f} MB")
    except PsdrRoomError as exc:
        print(f"psdr-room-cache: error: {exc}", file=sys.stderr)
        return 2
    return 0
