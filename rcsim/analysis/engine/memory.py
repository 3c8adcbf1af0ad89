"""Handing freed memory back to the operating system between the stages of a long job.

glibc's allocator keeps the memory a stage freed (its arenas, and large blocks it stopped
mapping separately once one was freed) for the process's next allocations, and so does
pyarrow's own pool (mimalloc in its Linux wheels), so a process that peaked in one stage holds
that peak for the rest of its life.  In ``rcsim loop`` the parent held ~490 MB after the driver
analysis, of which ~170 MB were free, and the later stages' worker processes came on top of it
(``docs/performance.md``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import sys
from functools import cache


@cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another C library, another system)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):  # musl and others have no malloc_trim
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


def give_back_free_memory() -> bool:
    """Collect cyclic garbage, then return the allocators' free pages to the system.

    Returns whether the C allocator could be asked (glibc); elsewhere only the collection and
    pyarrow's pool (when pyarrow is loaded) give memory back.  Costs a few milliseconds: call
    it between stages, not in a loop.
    """
    gc.collect()
    arrow = sys.modules.get("pyarrow")  # never imported for this
    if arrow is not None:
        arrow.default_memory_pool().release_unused()
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True


__all__ = ["give_back_free_memory"]
