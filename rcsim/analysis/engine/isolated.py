"""Work that may crash the process it runs in (a user's C flight code), run in a child.

A segfault inside a library called through ctypes ends the process; nothing in Python can
catch it.  :func:`call_isolated` runs ``fn(item)`` for each item in a child process started
fresh (the ``spawn`` method: no fork of a process with MuJoCo threads), sends each result back
as it is made, and when the child dies mid-item, says which item, with what signal, and at
which control cycle: the child's C-library controllers write their cycle to a *beacon* file
before each call (:data:`rcsim.lookup.c_library.BEACON_ENV`).  The items after the crashed one
go on in a new child.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import tempfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rcsim.lookup.c_library import BEACON_ENV, read_beacon


@dataclass(frozen=True)
class Crash:
    """How the child died during one item.

    Attributes
    ----------
    exitcode : int
        The child's exit code (negative: killed by that signal).
    cycle : int or None
        The control cycle the item's controller had reached (None: no C controller was
        stepping, e.g. the crash came before the first cycle).
    t_s : float or None
        That cycle's time [s].
    """

    exitcode: int
    cycle: int | None
    t_s: float | None

    def describe(self) -> str:
        """``"crashed (SIGSEGV) at cycle 12 (t = 0.48 s)"``."""
        if self.exitcode < 0:
            try:
                how = signal.Signals(-self.exitcode).name
            except ValueError:
                how = f"signal {-self.exitcode}"
        else:
            how = f"exit code {self.exitcode}"
        where = "" if self.cycle is None else f" at cycle {self.cycle} (t = {self.t_s:g} s)"
        return f"crashed ({how}){where}"


class _ChildError(Exception):
    """An exception the child raised, carried back to be raised again here."""


def _child(fn: Callable, items: Sequence, conn, beacon: str) -> None:
    os.environ[BEACON_ENV] = beacon
    for i, item in enumerate(items):
        Path(beacon).write_text("")  # a crash before this item's first cycle reads as such
        try:
            result = fn(item)
        except BaseException as exc:  # noqa: BLE001 - sent back and raised in the parent
            conn.send((i, "error", exc))
            return
        conn.send((i, "ok", result))
    conn.close()


def call_isolated(fn: Callable, items: Sequence) -> Iterator[tuple[Any, Any]]:
    """Yield ``(item, fn(item))`` for each item, or ``(item, Crash)`` for one whose call ended
    the child process; ``fn`` must be picklable by reference (a module-level function).

    An exception ``fn`` raises in the child is raised here (the rest are not run).
    """
    items = list(items)
    ctx = multiprocessing.get_context("spawn")
    start = 0
    with tempfile.TemporaryDirectory(prefix="rcsim-isolated-") as tmp:
        while start < len(items):
            beacon = str(Path(tmp) / f"beacon-{start}")
            Path(beacon).write_text("")
            recv, send = ctx.Pipe(duplex=False)
            child = ctx.Process(target=_child, args=(fn, items[start:], send, beacon))
            child.start()
            send.close()  # the child holds the only write end: EOF when it dies
            done = 0
            try:
                while True:
                    try:
                        i, kind, value = recv.recv()
                    except EOFError:
                        break
                    if kind == "error":
                        raise value
                    yield items[start + i], value
                    done = i + 1
            finally:
                recv.close()
                child.join(timeout=30)
                if child.is_alive():  # the consumer stopped early: do not leave it running
                    child.kill()
                    child.join()
            start += done
            if start >= len(items):
                return
            at = read_beacon(beacon)
            crash = Crash(
                exitcode=child.exitcode if child.exitcode is not None else -1,
                cycle=None if at is None else at[0],
                t_s=None if at is None else at[1],
            )
            yield items[start], crash
            start += 1
