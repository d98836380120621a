"""Peak resident memory (RSS) of one piece of work in this process.

On Linux the kernel keeps the process's high-water mark (``VmHWM``) and resets it on request
(``/proc/self/clear_refs``), so each stage's peak is its own. Elsewhere the peak is the process's so far
(``getrusage``), which bounds the stage's from above.
"""

from __future__ import annotations

import re
import resource
import sys
from pathlib import Path
from types import TracebackType

_STATUS, _CLEAR = Path("/proc/self/status"), Path("/proc/self/clear_refs")


class PeakMemory:
    """``with PeakMemory() as peak: ...`` then ``peak.megabytes``: the highest RSS while the block ran
    (``own``: whether it was measured from the block's start, not from the process's)."""

    def __init__(self) -> None:
        self.megabytes = 0.0
        self.own = False

    def __enter__(self) -> PeakMemory:
        try:
            _CLEAR.write_text("5")  # reset the high-water mark to the current RSS
            self.own = True
        except OSError:
            self.own = False
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, tb: TracebackType | None) -> None:
        self.megabytes = _high_water_kib() / 1024.0


def _high_water_kib() -> float:
    try:
        found = re.search(r"^VmHWM:\s+(\d+)\s+kB", _STATUS.read_text(), re.MULTILINE)
        if found:
            return float(found.group(1))
    except OSError:
        pass
    peak = float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return peak / 1024.0 if sys.platform == "darwin" else peak  # bytes on macOS, KiB elsewhere
