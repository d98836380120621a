"""A run's input file (``image=PATH``) and a sweep's (``photos=DIR`` or a glob): found, and refused in one line."""

from __future__ import annotations

import glob
import os
from pathlib import Path

from .errors import PsdrRoomError

EXTENSIONS = (".jpg", ".jpeg", ".png", ".tif", ".tiff", ".webp", ".mpo")
"""File name endings (any case) that :func:`find_photos` takes for photos."""


def require_file(path: Path) -> None:
    """One line for a photo path that is a directory, does not exist, is empty or cannot be read."""
    if path.is_dir():
        raise PsdrRoomError(f"{path}: is a directory; pass image=PATH to a photo file")
    if not path.is_file():
        raise PsdrRoomError(f"{path}: no such file; pass image=PATH to an existing photo")
    if path.stat().st_size == 0:
        raise PsdrRoomError(f"{path}: the file is empty; copy the photo again")
    if not os.access(path, os.R_OK):
        raise PsdrRoomError(f"{path}: cannot be read (permission denied); make it readable (chmod a+r) or copy it")


def find_photos(spec: str) -> list[Path]:
    """The photos of ``photos=spec``: the images directly in a folder, or those a glob matches (``**``
    descends), sorted. An image named ``<stem>.<anything>.<ext>`` beside a photo ``<stem>.<ext>`` is one
    of its sidecars (``photo.depth.png``, ``photo.panoptic.png``) and left out."""
    path = Path(spec).expanduser()
    if path.is_dir():
        candidates = [p for p in path.iterdir() if p.is_file()]
    elif glob.has_magic(spec):
        candidates = [Path(p) for p in glob.glob(str(path), recursive=True) if Path(p).is_file()]
    else:
        raise PsdrRoomError(
            f"photos={spec}: no such folder; give photos=DIR (the images in it) or a quoted glob "
            "such as photos='rooms/*/photo.png'"
        )
    images = sorted(p for p in candidates if p.suffix.lower() in EXTENSIONS)
    stems = {(p.parent, p.stem) for p in images}
    photos = [p for p in images if not _is_sidecar(p, stems)]
    if not photos:
        raise PsdrRoomError(
            f"photos={spec}: no photos in it (looked for {', '.join(EXTENSIONS)}, sidecars left "
            "out); point it at a folder of room photos"
        )
    return photos


def _is_sidecar(image: Path, stems: set[tuple[Path, str]]) -> bool:
    parts = image.name.split(".")
    return any((image.parent, ".".join(parts[:i])) in stems for i in range(1, len(parts) - 1))
