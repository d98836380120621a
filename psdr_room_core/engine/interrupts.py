"""SIGTERM as Ctrl-C: a command stopped by ``kill``, a scheduler or a container's stop cleans up as an interrupted one
does, its ``finally`` blocks removing its scratch files (:mod:`.debris`). SIGKILL cannot be caught: what it leaves is
swept by the next command that writes there."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """While inside, SIGTERM raises :class:`KeyboardInterrupt` in the main thread; the previous handler is restored
    after. Outside the main thread (a run in the studio's worker) it changes nothing: only the main thread can."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def was_interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is a :class:`KeyboardInterrupt` or was raised because of one (an extension module interrupted
    while it loads raises ImportError from it)."""
    cause: BaseException | None = exc
    while cause is not None:
        if isinstance(cause, KeyboardInterrupt):
            return True
        cause = cause.__cause__ or cause.__context__
    return False
