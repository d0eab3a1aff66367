"""Keeping a long run's memory at what it holds: big freed arrays go back to the operating system.

glibc's ``malloc`` serves a request of at least its *mmap threshold* with a private mapping, which ``free``
unmaps at once; smaller requests come from the heap, which only shrinks from its top.  The threshold starts at
128 KiB and, by default, *rises* to the size of every mapped block freed (up to 32 MiB).  A SLAM run frees
megabyte arrays all the time (tile pools that grow, loop-closure search grids, the tile tables copied at each
resampling), so after a while those arrays land on the heap between long-lived ones, and the freed space stays
resident: a long run's peak memory then depends on where its frees happened to land, not on what it holds.

:func:`return_big_frees_to_os` fixes the threshold (which also stops it rising), so every array of
``threshold_bytes`` or more is mapped and unmapped on its own and goes back to the system when freed.  8 MiB is
below the arrays that matter (tile pools, search grids, tile tables) and above the many small ones, whose every
allocation would otherwise cost page faults.  The ``mcnkit`` command calls it once at start; a notebook or script
may call it too (``benchmarks/bench_buildings.py`` reports the runs' peak RSS).  Elsewhere than glibc (macOS, musl) it does nothing and says so by
returning False.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["DEFAULT_THRESHOLD_BYTES", "return_big_frees_to_os"]

DEFAULT_THRESHOLD_BYTES = 8 * 2**20
_M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter number (malloc.h)


def return_big_frees_to_os(threshold_bytes: int = DEFAULT_THRESHOLD_BYTES) -> bool:
    """Makes allocations of ``threshold_bytes`` or more private mappings, returned to the OS when freed.

    Returns True when glibc accepted the setting, False where the C library is not glibc or refused it."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, int(threshold_bytes)))
