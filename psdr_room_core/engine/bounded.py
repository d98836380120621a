"""Reading a user's JSON files within limits: a file larger than its kind ever is, JSON nested deeper than the
parser's recursion allows, a string of megabytes are each refused in one line naming the file, before anything is
parsed; and :func:`excerpt`, how much of a bad value an error line shows."""

from __future__ import annotations

import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import PsdrRoomError

ECHO = 80
"""Characters of a bad value an error line shows at most."""


def excerpt(text: str) -> str:
    """``text`` (a bad value as the error line writes it) cut to :data:`ECHO` characters, with an ellipsis."""
    return text if len(text) <= ECHO else text[: ECHO - 1] + "…"


def size_text(count: int) -> str:
    """A byte count for people: ``2.0 MB``, ``40.0 GB``."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if count >= scale:
            return f"{count / scale:.1f} {unit}"
    return f"{count} bytes"


@dataclass(frozen=True)
class JsonLimits:
    """What a JSON file of one kind may hold."""

    max_bytes: int
    max_depth: int = 32
    """Levels of nested arrays and objects (the parser recurses once per level)."""
    max_string: int = 1 << 20
    """Characters in one string, as written in the file."""


_TOKENS = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[\[\]{}]')
"""A JSON string (escapes included) or a bracket outside strings."""


def load_json(path: Path, limits: JsonLimits, fix: str) -> Any:
    """The JSON value in ``path``, parsed once its size, nesting and longest string are within ``limits``; a file
    outside them is a one-line :class:`PsdrRoomError` naming ``path`` and ending in ``fix``. Otherwise raises as
    ``json.loads(path.read_text())`` would: OSError, UnicodeDecodeError, json.JSONDecodeError."""
    with open(path, "rb") as file:
        data = file.read(limits.max_bytes + 1)
    if len(data) > limits.max_bytes:
        raise PsdrRoomError(
            f"{path}: {size_text(os.path.getsize(path))}, larger than such a file ever is "
            f"(at most {size_text(limits.max_bytes)}); {fix}"
        )
    text = data.decode("utf-8")
    depth = 0
    for token in _TOKENS.finditer(text):
        opening = token.group()
        if opening[0] == '"':
            if len(opening) - 2 > limits.max_string:
                raise PsdrRoomError(
                    f"{path}: a string of {len(opening) - 2:,} characters ({_place(text, token.start())}), over the "
                    f"{limits.max_string:,} allowed; {fix}"
                )
        elif opening in "[{":
            depth += 1
            if depth > limits.max_depth:
                raise PsdrRoomError(
                    f"{path}: nested more than {limits.max_depth} levels deep ({_place(text, token.start())}); {fix}"
                )
        else:
            depth -= 1
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        raise
    except ValueError:  # an integer of more digits than Python converts
        raise PsdrRoomError(f"{path}: a number of over {sys.get_int_max_str_digits():,} digits; {fix}") from None


def _place(text: str, offset: int) -> str:
    line_start = text.rfind("\n", 0, offset) + 1
    line = text.count("\n", 0, offset) + 1
    return f"line {line}, column {offset - line_start + 1}"
