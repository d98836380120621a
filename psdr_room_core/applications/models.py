"""``psdr-room-models``: list, download and verify the model files neural implementations read.

    psdr-room-models list [--models-dir DIR]          every model, its file, checksum, licence, source, status
    psdr-room-models info NAME                        one model in full, with how to obtain it by hand
    psdr-room-models download NAME... [--models-dir DIR] [--force]
    psdr-room-models verify [NAME...] [--models-dir DIR]

The models directory is ``--models-dir``, else ``$PSDR_ROOM_MODELS_DIR``, else
``<user data dir>/psdr-room/models``; the registry is ``psdr_room_core/method/models.json`` plus plugins'
(``model_registries`` hook) plus any ``--registry FILE``. Every command first removes what a download killed
in that directory left (its scratch ``.part`` file, :func:`~psdr_room_core.engine.debris.sweep`) and says so in
one line. Errors are one line on stderr, exit status 2; ``verify`` exits 1 when a file is corrupt (or a named one
missing).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from psdr_room_core.engine.debris import sweep
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import models

PROG = "psdr-room-models"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="List, download and verify model files for psdr-room.")
    parser.add_argument(
        "--registry",
        action="append",
        type=Path,
        default=[],
        metavar="FILE",
        help="an extra model-registry JSON file (repeatable)",
    )
    dir_option = argparse.ArgumentParser(add_help=False)
    dir_option.add_argument(
        "--models-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help=f"models directory (default: ${models.MODELS_DIR_ENV}, else "
        f"{models.user_data_dir() / 'psdr-room' / 'models'})",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="{list,info,download,verify}")
    listing = commands.add_parser("list", parents=[dir_option], help="every model and whether it is installed")
    listing.add_argument("--capability", default=None, help="only models of this capability (depth, segmentation, ...)")
    info = commands.add_parser("info", parents=[dir_option], help="one model in full, with how to obtain it")
    info.add_argument("name")
    download = commands.add_parser("download", parents=[dir_option], help="download models into the models dir")
    download.add_argument("names", nargs="+", metavar="NAME")
    download.add_argument("--force", action="store_true", help="download even if installed and verified")
    download.add_argument("--quiet", action="store_true", help="no progress bar")
    check = commands.add_parser("verify", parents=[dir_option], help="check installed files against their checksums")
    check.add_argument("names", nargs="*", metavar="NAME")
    return parser


def text_table(rows: list[list[str]]) -> str:
    """Rows of cells as left-aligned columns (the first row is the header); the commands' list output."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows)


def _list(registry: dict[str, models.ModelEntry], models_dir: Path, capability: str | None) -> int:
    entries = [e for e in registry.values() if capability is None or e.capability == capability]
    print(f"models dir: {models_dir}" + ("" if models_dir.is_dir() else " (does not exist yet)"))
    rows = [["capability", "name", "file", "size", "sha256", "licence", "status", "source"]]
    for entry in sorted(entries, key=lambda e: (models.USES.index(e.capability), e.name)):
        status = models.check_file(entry, models_dir)
        state = {"unverified": "installed (unverified)"}.get(status.state, status.state)
        if status.state == "missing" and not entry.url:
            state = "missing (export by hand: info)"
        rows.append(
            [
                entry.capability,
                entry.name,
                entry.file,
                entry.size_text(),
                entry.checksum[:12] + ("…" if entry.sha256 else "") if entry.checksum else "-",
                entry.licence,
                state,
                entry.url or entry.source,
            ]
        )
    print(text_table(rows))
    return 0


def _info(entry: models.ModelEntry, models_dir: Path) -> int:
    status = models.check_file(entry, models_dir)
    lines = [
        ("name", entry.name),
        ("capability", entry.capability),
        ("family", entry.family),
        ("description", entry.description),
        ("file", str(status.path)),
        ("size", entry.size_text()),
        ("sha256", entry.checksum or "unpublished"),
        ("checksum from", entry.checksum_source or "-"),
        ("licence", entry.licence),
        ("source", entry.source),
        ("url", entry.url or "none (export by hand)"),
        ("status", status.describe()),
        ("obtain", entry.obtain),
        ("registry", entry.registry),
    ]
    width = max(len(k) for k, _ in lines)
    print("\n".join(f"{k.ljust(width)}  {v}" for k, v in lines))
    return 0


def _download(
    registry: dict[str, models.ModelEntry], models_dir: Path, names: Sequence[str], *, force: bool, quiet: bool
) -> int:
    for name in names:  # all names first: a typo fails before anything is fetched
        models.lookup(name, registry)
    for name in names:
        path = models.download(name, models_dir, registry, progress=not quiet, force=force)
        status = models.check_file(registry[name], models_dir)
        print(f"{name}: {path} ({status.describe()})")
    return 0


def _verify(registry: dict[str, models.ModelEntry], models_dir: Path, names: Sequence[str]) -> int:
    results = models.verify(models_dir, registry, names)
    bad = False
    for status in results:
        print(f"{status.entry.name}: {status.describe()} ({status.path})")
        bad |= status.state == "corrupt" or (bool(names) and status.state == "missing")
    for status in results:
        if status.state == "corrupt":
            print(
                f"{PROG}: {status.path} is corrupt; run `{PROG} download {status.entry.name} --force`", file=sys.stderr
            )
    return 1 if bad else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``psdr-room-models``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        files = models.registry_files() + list(args.registry)
        registry = models.load_registry(files)
        models_dir = models.resolve_models_dir(args.models_dir)
        sweep(models_dir, "download")
        if args.command == "list":
            return _list(registry, models_dir, args.capability)
        if args.command == "info":
            return _info(models.lookup(args.name, registry), models_dir)
        if args.command == "download":
            return _download(registry, models_dir, args.names, force=args.force, quiet=args.quiet)
        return _verify(registry, models_dir, args.names)
    except PsdrRoomError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; nothing half-written was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
