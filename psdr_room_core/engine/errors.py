"""The one error type users see: a one-line message naming the file or setting and the fix."""

from __future__ import annotations


class PsdrRoomError(Exception):
    """A problem with the user's input or configuration.

    The CLI prints ``str(error)`` as a single line and exits non-zero, without a traceback, so the message
    must say what is wrong, where (file or config key), and how to fix it.
    """

    exit_code = 2

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(message.split()))
