"""The one error type users see: a one-line message naming the file or setting and the fix."""

from __future__ import annotations

import errno
from pathlib import Path


class PsdrRoomError(Exception):
    """A problem with the user's input or configuration.

    The CLI prints ``str(error)`` as a single line and exits non-zero, without a traceback, so the message
    must say what is wrong, where (file or config key), and how to fix it.
    """

    exit_code = 2

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(message.split()))


def disk_full(exc: BaseException, folder: Path) -> PsdrRoomError | None:
    """The one-line error for ``exc`` when it is a full disk (ENOSPC) met while writing under ``folder`` (the
    file's own folder where the error names it), else None."""
    if not isinstance(exc, OSError) or exc.errno != errno.ENOSPC:
        return None
    where = Path(exc.filename).parent if exc.filename else folder
    return PsdrRoomError(f"{where}: no space left on device; free some space there or choose a folder on another disk")
