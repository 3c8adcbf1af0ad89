"""Freed heap goes back to the system between stages (rcsim/analysis/engine/memory.py)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from rcsim.analysis.engine.memory import _malloc_trim, give_back_free_memory


def test_without_glibc_only_the_collection_runs(monkeypatch):
    from rcsim.analysis.engine import memory

    monkeypatch.setattr(memory, "_malloc_trim", lambda: None)
    assert give_back_free_memory() is False


@pytest.mark.skipif(_malloc_trim() is None, reason="needs glibc's malloc_trim")
def test_freed_heap_is_returned_to_the_system():
    # 160 MB in 64 KB arrays (below glibc's mmap threshold: they come from the heap), the
    # last one kept so the heap's top cannot shrink by itself: freeing the others leaves the
    # resident size where it was until the allocator is asked to give the pages back.  Run in
    # a fresh interpreter so that no earlier test's heap state (thresholds moved by freed
    # large blocks) decides where the arrays come from.
    script = textwrap.dedent(
        """
        import numpy as np
        from rcsim.analysis.engine.memory import give_back_free_memory

        def rss_mb():
            for line in open("/proc/self/status"):
                if line.startswith("VmRSS"):
                    return int(line.split()[1]) / 1024

        blocks = [np.ones(8192) for _ in range(2560)]
        keep = blocks[-1]
        del blocks
        held = rss_mb()
        assert give_back_free_memory() is True
        print(held - rss_mb())
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    ).stdout
    # At least 100 of the 160 MB freed come back (the rest: allocator bookkeeping, pages
    # the kernel had not yet handed out).
    assert float(out) > 100.0, out
