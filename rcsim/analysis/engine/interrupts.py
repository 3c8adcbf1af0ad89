"""Stopping long work: SIGTERM as a clean, resumable stop, told apart from Ctrl-C.

A terminal's Ctrl-C raises :class:`KeyboardInterrupt`; a ``kill`` (SIGTERM, what schedulers and
``timeout`` send) would end the process on the spot.  Inside :func:`sigterm_interrupts` it
raises :class:`Terminated` instead, a KeyboardInterrupt, so every writer's cleanup runs the
same way for both, and the command can exit with the shell's convention for the signal:
130 (128 + SIGINT) after Ctrl-C, 143 (128 + SIGTERM) after SIGTERM.  From the interrupt to
the end of the block, logging is disabled: the stop is told in one line, by the command.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading

#: Exit statuses of a command a signal stopped (the shell's 128 + signal number).
INTERRUPTED = 128 + int(signal.SIGINT)
TERMINATED = 128 + int(signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM stopped the work: the same clean, resumable stop as Ctrl-C (a
    KeyboardInterrupt), told apart so that a command can exit with 128 + SIGTERM."""

    signum = signal.SIGTERM


#: Interrupts received inside the outermost :func:`sigterm_interrupts` block (signal numbers),
#: for :func:`raise_if_interrupted`.
_received: list[int] = []
_depth = 0


@contextlib.contextmanager
def sigterm_interrupts():
    """While the block runs in the main thread, SIGTERM raises :class:`Terminated`.

    Nested uses are harmless (the innermost handler raises the same exception).  Library code
    that turns the interrupt into another KeyboardInterrupt on its way out is corrected: the
    exception that leaves the block is a :class:`Terminated` whenever SIGTERM arrived.

    Every interrupt inside the block, Ctrl-C (while SIGINT has Python's own handler) as well
    as SIGTERM, is also remembered, for :func:`raise_if_interrupted`: library code can swallow
    the exception a signal handler raised (numpy's comparison of a dtype with a string, which
    pandas makes while pyarrow converts a table, clears any exception raised while it runs),
    and the work would then run to its end as if no one had asked it to stop.
    """
    global _depth
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received = []
    hushed = logging.root.manager.disable

    def interrupt(signum, frame):
        received.append(signum)
        _received.append(signum)
        _hush()
        raise Terminated

    def ctrl_c(signum, frame):
        _received.append(signum)
        _hush()
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, interrupt)
    old_int = signal.getsignal(signal.SIGINT)
    if old_int is signal.default_int_handler:  # a caller's own SIGINT handling stays
        signal.signal(signal.SIGINT, ctrl_c)
    _depth += 1
    try:
        yield
    except KeyboardInterrupt as exc:
        if received and not isinstance(exc, Terminated):
            raise Terminated from exc
        raise
    finally:
        _depth -= 1
        if _depth == 0:
            _received.clear()
            logging.disable(hushed)
        signal.signal(signal.SIGTERM, old)
        if old_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, old_int)


def _hush() -> None:
    """Interrupted: libraries' logs stay unsaid until the block ends (a Dask cluster winding
    down logs every closed stream and cancelled task); the command's one line says it all."""
    logging.disable(logging.CRITICAL)


def raise_if_interrupted() -> None:
    """Raise the interrupt that arrived inside :func:`sigterm_interrupts` if something
    swallowed it: :class:`Terminated` after SIGTERM, :class:`KeyboardInterrupt` after Ctrl-C.

    Call it where long work goes on normally after a step (a chunk committed): reached there,
    an interrupt was received but no exception is on its way out.
    """
    if not _received:
        return
    last = _received[-1]
    _received.clear()
    if last == signal.SIGTERM:
        raise Terminated
    raise KeyboardInterrupt
