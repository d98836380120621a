"""The one error type users see: a one-line message naming the file or setting and the fix."""

from __future__ import annotations

import errno
import sys
from collections.abc import Callable
from pathlib import Path

from .interrupts import sigterm_interrupts, was_interrupted


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


def exit_status(program: str, folder: Path, action: Callable[[], object]) -> int:
    """Run ``action`` with SIGTERM taken as Ctrl-C: 0 when it returns; a :class:`PsdrRoomError`, a full disk under
    ``folder`` or an interrupt is one ``<program>: error:`` line on stderr and its status (130 interrupted).
    Anything else propagates."""
    try:
        with sigterm_interrupts():
            action()
        return 0
    except PsdrRoomError as exc:
        message, code = str(exc), exc.exit_code
    except (OSError, KeyboardInterrupt, ImportError) as exc:
        full = disk_full(exc, folder)
        if full is not None:
            message, code = str(full), full.exit_code
        elif was_interrupted(exc):
            message, code = "interrupted; rerun the same command", 130
        else:
            raise
    print(f"{program}: error: {message}", file=sys.stderr)
    return code
