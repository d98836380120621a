"""Reading a user's ``.npy`` file within limits: an array header that declares more data than such a file may hold,
or than the file holds, is refused in one line naming the file before anything is allocated."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from psdr_room_core.engine.bounded import size_text
from psdr_room_core.engine.errors import PsdrRoomError


def load_npy(path: Path, max_bytes: int, fix: str) -> np.ndarray:
    """The array in the ``.npy`` file ``path``, read once its header (``np.lib.format``) declares at most
    ``max_bytes`` of data and the file holds that much; otherwise a one-line :class:`PsdrRoomError` naming ``path``
    and ending in ``fix``, before anything is allocated. Raises OSError, and ValueError for a file that is not an
    ``.npy`` array (an ``.npz`` archive, another format, object arrays), as ``np.load`` would."""
    with open(path, "rb") as file:
        if file.read(4) == b"PK\x03\x04":
            raise ValueError("an .npz archive, not a single array")
        file.seek(0)
        version = np.lib.format.read_magic(file)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(file)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(file)
        else:
            raise ValueError(f".npy format version {version[0]}.{version[1]} is not read; save it with numpy.save")
        declared = math.prod(shape) * dtype.itemsize
        what = f"the header declares a {'x'.join(map(str, shape)) or 'scalar'} {dtype} array ({size_text(declared)})"
        if declared > max_bytes:
            raise PsdrRoomError(f"{path}: {what}, over the {size_text(max_bytes)} such a file may hold; {fix}")
        held = os.fstat(file.fileno()).st_size - file.tell()
        if held < declared:
            raise PsdrRoomError(f"{path}: {what} but holds only {size_text(held)}; {fix}")
        file.seek(0)
        return np.lib.format.read_array(file, allow_pickle=False)
