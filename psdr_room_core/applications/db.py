"""``psdr-room-db``: list, render and export object model databases.

    psdr-room-db list [--category C]                      id, category, groups, size (m), name
    psdr-room-db build                                     render every missing thumbnail (progress bar)
    psdr-room-db show ID --out PNG                         a contact sheet of one model's views
    psdr-room-db sheet --out PNG [--category C] [--columns N]   one thumbnail per model, labelled with its id
    psdr-room-db export --out DIR                          write the database in our format (index.json, <id>/...)
    psdr-room-db index --root DIR                          (re)write DIR/index.json from its <id>/model.json files

Every command reads the built-in library unless given ``--root DIR`` (a database in our format) or
``--3d-future DIR`` (the official 3D-FUTURE layout); ``--subset F --seed S`` keeps a fraction per category.
Thumbnails are cached under ``$PSDR_ROOM_CACHE_DIR`` (default ``~/.cache/psdr-room``)/object_db/. Errors
are one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import write_png

if TYPE_CHECKING:
    from psdr_room_core.libraries.object_db.database import ModelRecord, ObjectDatabase

PROG = "psdr-room-db"


def _parser() -> argparse.ArgumentParser:
    source = argparse.ArgumentParser(add_help=False)
    group = source.add_argument_group("database (default: the built-in library)")
    where = group.add_mutually_exclusive_group()
    where.add_argument("--root", type=Path, metavar="DIR", help="a database in psdr-room's format (index.json)")
    where.add_argument(
        "--3d-future",
        dest="future",
        type=Path,
        metavar="DIR",
        help="a 3D-FUTURE folder (model_info.json, 3D-FUTURE-model/)",
    )
    group.add_argument("--subset", type=float, default=None, metavar="F", help="keep this fraction per category")
    group.add_argument("--seed", type=int, default=0, help="seed of --subset (default 0)")
    parser = argparse.ArgumentParser(prog=PROG, description="Object model databases of psdr-room.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="{list,build,show,sheet,export,index}")
    listing = commands.add_parser("list", parents=[source], help="the models")
    listing.add_argument("--category", help="only this category")
    commands.add_parser("build", parents=[source], help="render missing thumbnails")
    show = commands.add_parser("show", parents=[source], help="one model's thumbnails as one image")
    show.add_argument("id", metavar="ID")
    show.add_argument("--out", type=Path, required=True, metavar="PNG")
    sheet = commands.add_parser("sheet", parents=[source], help="a contact sheet of the database")
    sheet.add_argument("--out", type=Path, required=True, metavar="PNG")
    sheet.add_argument("--category", help="only this category")
    sheet.add_argument("--columns", type=int, default=12, help="thumbnails per row (default 12)")
    sheet.add_argument("--view", type=int, default=0, help="which view (default 0, front-right)")
    export = commands.add_parser("export", parents=[source], help="write the database in psdr-room's format")
    export.add_argument("--out", type=Path, required=True, metavar="DIR")
    index = commands.add_parser("index", help="rebuild DIR/index.json from DIR/<id>/model.json")
    index.add_argument("--root", type=Path, required=True, metavar="DIR")
    return parser


def open_database(
    root: Path | None = None, future: Path | None = None, subset: float | None = None, seed: int = 0
) -> ObjectDatabase:
    from psdr_room_core.libraries.object_db.builtin import builtin_database
    from psdr_room_core.libraries.object_db.database import ObjectDatabase

    if root is not None:
        db = ObjectDatabase.load(root)
    elif future is not None:
        from psdr_room_core.libraries.object_db.future3d import read_3dfuture

        db = read_3dfuture(future)
    else:
        db = builtin_database()
    return db.subset(subset, seed) if subset is not None else db


def _progress(total: int, what: str) -> Callable[[Iterable[ModelRecord]], Iterable[ModelRecord]]:
    from tqdm import tqdm

    return lambda items: tqdm(
        items,
        total=total,
        desc=what,
        unit="model",
        file=sys.stderr,
        disable=None if sys.stderr.isatty() else False,
        mininterval=1.0,
    )


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except PsdrRoomError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted (finished thumbnails stay cached)", file=sys.stderr)
        return 130


def _run(args: argparse.Namespace) -> int:
    if args.command == "index":
        from psdr_room_core.libraries.object_db.database import build_index

        print(f"wrote {build_index(args.root)}")
        return 0
    from psdr_room_core.libraries.object_db.thumbnails import build_thumbnails, cache_dir
    from psdr_room_core.method.visualize import contact_sheet

    db = open_database(args.root, args.future, args.subset, args.seed)
    if args.command == "list":
        records = db.category(args.category) if args.category else db.records
        for r in records:
            size = "x".join(f"{e:.2f}" for e in r.extent)
            print(f"{r.id}\t{r.category}\t{','.join(r.groups)}\t{size}\t{r.name}")
        counts = ", ".join(f"{c} {n}" for c, n in db.categories().items())
        print(f"{len(records)} of {len(db)} models ({counts})", file=sys.stderr)
        return 0
    if args.command == "build":
        start = time.perf_counter()
        rendered, cached = build_thumbnails(db, progress=_progress(len(db), "thumbnails"))
        print(f"{rendered} rendered, {cached} already cached, in {cache_dir(db)} ({time.perf_counter() - start:.0f} s)")
        return 0
    if args.command == "show":
        record = db.record(args.id)
        views = db.thumbnails(record.id)
        write_png(args.out, contact_sheet([(f"{record.id} #{k}", v) for k, v in enumerate(views)], columns=len(views)))
        print(f"{record.id} ({record.category}, groups {', '.join(record.groups)}): {args.out}")
        return 0
    if args.command == "sheet":
        records = db.category(args.category) if args.category else db.records
        build_thumbnails(db.only(r.id for r in records), progress=_progress(len(records), "thumbnails"))
        images = []
        for record in records:
            views = db.thumbnails(record.id)
            images.append((record.id, views[min(max(args.view, 0), len(views) - 1)]))
        write_png(args.out, contact_sheet(images, columns=args.columns))
        print(f"contact sheet of {len(images)} models: {args.out}")
        return 0
    if args.command == "export":
        index = db.save(args.out, progress=_progress(len(db), "export"))
        print(f"wrote {len(db)} models and {index}")
        return 0
    raise AssertionError(args.command)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
