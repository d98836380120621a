"""``psdr-room-materials``: list, render and preview the procedural material library.

    psdr-room-materials list [--dir DIR]                       name, category, nodes, parameters, description
    psdr-room-materials nodes                                  every node type with its parameters
    psdr-room-materials render NAME... [--out DIR] [--size N] [--thumb-size N] [--spp N] [--no-thumbnail]
                                                               the output maps and the Mitsuba thumbnail
    psdr-room-materials thumbs [--out DIR] [--sheet PNG] [--size N] [--spp N] [--columns N]
                                                               every thumbnail, and a contact sheet

Thumbnails are rendered with ``renderer=mitsuba``'s variant selection (LLVM needs libLLVM >= 16); graphs
are the built-in library, the plugins' and ``--dir`` directories. Errors are one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from psdr_room_core.applications.models import text_table
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import write_png

PROG = "psdr-room-materials"
DEFAULT_OUT = Path("materials")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="The procedural material library of psdr-room.")
    parser.add_argument(
        "--dir",
        action="append",
        type=Path,
        default=[],
        metavar="DIR",
        help="an extra directory of graph files (repeatable)",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="{list,nodes,render,thumbs}")
    commands.add_parser("list", help="every material")
    commands.add_parser("nodes", help="every node type and its parameters")
    render = commands.add_parser("render", help="maps and thumbnail of materials")
    render.add_argument("names", nargs="+", metavar="NAME")
    render.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output directory (default: ./materials)")
    render.add_argument("--size", type=int, default=512, help="map resolution (default 512)")
    render.add_argument("--thumb-size", type=int, default=256, help="thumbnail resolution (default 256)")
    render.add_argument("--spp", type=int, default=256, help="thumbnail samples per pixel (default 256)")
    render.add_argument("--no-thumbnail", action="store_true", help="only the maps (no Mitsuba)")
    thumbs = commands.add_parser("thumbs", help="every thumbnail and a contact sheet")
    thumbs.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output directory (default: ./materials)")
    thumbs.add_argument("--sheet", type=Path, default=None, help="contact sheet PNG (default: OUT/contact_sheet.png)")
    thumbs.add_argument("--size", type=int, default=192, help="thumbnail resolution (default 192)")
    thumbs.add_argument("--map-size", type=int, default=512, help="resolution of the maps rendered (default 512)")
    thumbs.add_argument("--spp", type=int, default=256, help="samples per pixel (default 256)")
    thumbs.add_argument("--columns", type=int, default=8, help="contact sheet columns (default 8)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except PsdrRoomError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return exc.exit_code


def _run(args: argparse.Namespace) -> int:
    import torch

    from psdr_room_core.method.visualize import contact_sheet
    from psdr_room_plugins.material_graph.library import TorchGraphLibrary
    from psdr_room_plugins.material_graph.thumbnails import ThumbnailRenderer, map_images, shade, tensor_to_uint8

    library = TorchGraphLibrary(extra_dirs=[str(d) for d in args.dir])
    if args.command == "list":
        rows = [["name", "category", "nodes", "params", "tile", "description"]]
        for material in library.materials():
            rows.append(
                [
                    material.name,
                    material.category,
                    str(len(material.nodes)),
                    str(len(material.parameters(requires_grad=False))),
                    f"{material.tile_size:g} m",
                    material.description,
                ]
            )
        print(text_table(rows))
        print(f"{len(rows) - 1} materials ({', '.join(str(d) for d in library.dirs)})")
        return 0
    if args.command == "nodes":
        for name, node_type in sorted(library.node_types.items()):
            ins = ", ".join(f"{k}{'' if v.required else '?'}" for k, v in node_type.inputs.items())
            print(
                f"{name} ({node_type.kind}{'; inputs ' + ins if ins else ''}; outputs "
                f"{', '.join(node_type.outputs)}): {node_type.doc}"
            )
            for key, spec in node_type.params.items():
                print(f"    {key}: {spec.describe()}{' - ' + spec.doc if spec.doc else ''}")
        return 0
    torch.set_grad_enabled(False)
    if args.command == "render":
        renderer = None if args.no_thumbnail else ThumbnailRenderer(args.thumb_size, args.spp, args.size)
        for name in args.names:
            material = library.material(name)
            maps = material.evaluate(args.size)
            folder = args.out / name
            for key, image in map_images(maps).items():
                write_png(folder / f"{key}.png", image)
            write_png(folder / "preview.png", tensor_to_uint8(shade(maps)))
            written = [f"{k}.png" for k in maps] + ["preview.png"]
            if renderer is not None:
                write_png(folder / "thumbnail.png", renderer.render(maps))
                written.append("thumbnail.png")
            print(f"{name}: {folder}/{{{','.join(written)}}}")
        return 0
    # thumbs
    renderer = ThumbnailRenderer(args.size, args.spp, args.map_size)
    images = []
    start = time.perf_counter()
    for name in library.names():
        image = renderer.render(library.material(name).evaluate(args.map_size))
        write_png(args.out / f"{name}.png", image)
        images.append((name, image))
        print(f"{name}: {args.out / (name + '.png')}", flush=True)
    sheet_path = args.sheet or args.out / "contact_sheet.png"
    write_png(sheet_path, contact_sheet(images, columns=args.columns, font_scale=0.4 if args.size >= 160 else 0.3))
    print(f"contact sheet: {sheet_path} ({len(images)} materials, {time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
