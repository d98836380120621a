"""Peak memory per piece of work (the stages' ``peak_rss_mb``): a block's own high-water mark, not the process's."""

from __future__ import annotations

import sys

import pytest

from psdr_room_core.engine.memory import PeakMemory


def test_a_block_that_allocates_peaks_higher_than_one_that_does_not() -> None:
    with PeakMemory() as large:
        block = bytearray(300 * 2**20)
        block[::4096] = b"x" * len(block[::4096])  # touch every page: resident, not just reserved
        del block
    with PeakMemory() as small:
        pass
    assert large.megabytes >= 300
    if sys.platform.startswith("linux") and small.own:  # the kernel's mark was reset: the large block is gone
        assert small.megabytes < large.megabytes - 250
    else:
        pytest.skip("no resettable high-water mark here: peaks are the process's so far")
