"""Work that may crash the process it runs in (a user's C flight code), run in a child.

A segfault inside a library called through ctypes ends the process; nothing in Python can
catch it.  :func:`call_isolated` runs ``fn(item)`` for each item in a child process started
fresh (a new interpreter: no fork of a process with MuJoCo threads), sends each result back
as it is made, and when the child dies mid-item, says which item, with what signal, and at
which control cycle: the child's C-library controllers write their cycle to a *beacon* file
before each call (:data:`rcsim.lookup.c_library.BEACON_ENV`).  The items after the crashed one
go on in a new child.
"""

from __future__ import annotations

import os
import pickle
import signal
import struct
import subprocess
import sys
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


def _send(stream, message) -> None:
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(struct.pack("<Q", len(data)) + data)
    stream.flush()


def _receive(stream):
    """The next message, or EOFError when the child is gone (mid-message too)."""
    head = stream.read(8)
    if len(head) < 8:
        raise EOFError
    size = struct.unpack("<Q", head)[0]
    data = stream.read(size)
    if len(data) < size:
        raise EOFError
    return pickle.loads(data)


def child_main() -> None:
    """The child: ``(fn, items, beacon)`` from stdin, one message per item on the original
    stdout (this process's own prints go to stderr, so they cannot corrupt the messages)."""
    channel = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    fn, items, beacon = pickle.load(sys.stdin.buffer)
    os.environ[BEACON_ENV] = beacon
    for i, item in enumerate(items):
        Path(beacon).write_text("")  # a crash before this item's first cycle reads as such
        try:
            result = fn(item)
        except BaseException as exc:  # noqa: BLE001 - sent back and raised in the parent
            _send(channel, (i, "error", exc))
            return
        _send(channel, (i, "ok", result))
    channel.close()


def call_isolated(fn: Callable, items: Sequence) -> Iterator[tuple[Any, Any]]:
    """Yield ``(item, fn(item))`` for each item, or ``(item, Crash)`` for one whose call ended
    the child process; ``fn`` must be picklable by reference (a module-level function).

    The child is a new Python process (``python -m rcsim.analysis.engine.isolated``; a
    subprocess, not multiprocessing, so that a daemonic process, such as a Dask worker's, may
    start it).  An exception ``fn`` raises in the child is raised here (the rest are not run).
    """
    items = list(items)
    start = 0
    with tempfile.TemporaryDirectory(prefix="rcsim-isolated-") as tmp:
        while start < len(items):
            beacon = str(Path(tmp) / f"beacon-{start}")
            Path(beacon).write_text("")
            child = subprocess.Popen(
                [sys.executable, "-m", "rcsim.analysis.engine.isolated"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
            )
            assert child.stdin is not None and child.stdout is not None
            done = 0
            try:
                pickle.dump((fn, items[start:], beacon), child.stdin)
                child.stdin.close()
                while True:
                    try:
                        i, kind, value = _receive(child.stdout)
                    except EOFError:
                        break
                    if kind == "error":
                        raise value
                    yield items[start + i], value
                    done = i + 1
                child.wait()  # it closed its end: finished, or died
            finally:
                child.stdout.close()
                if child.poll() is None:  # the consumer stopped early: do not leave it running
                    child.kill()
                    child.wait()
            start += done
            if start >= len(items):
                return
            at = read_beacon(beacon)
            yield (
                items[start],
                Crash(
                    exitcode=child.returncode,
                    cycle=None if at is None else at[0],
                    t_s=None if at is None else at[1],
                ),
            )
            start += 1


def run_isolated(fn: Callable, item: Any, *, who: str) -> Any:
    """``fn(item)`` in a child process; a crash there is an InputError of one line, ``who``
    (e.g. ``"--controller library:libfsw.so"``) then the signal and the control cycle."""
    from rcsim.models.errors import InputError

    ((_, result),) = call_isolated(fn, [item])
    if isinstance(result, Crash):
        raise InputError(f"{who}: the flight software {result.describe()}")
    return result


if __name__ == "__main__":
    child_main()
