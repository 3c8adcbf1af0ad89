"""Stopping long work: SIGTERM as a clean, resumable stop, told apart from Ctrl-C.

A terminal's Ctrl-C raises :class:`KeyboardInterrupt`; a ``kill`` (SIGTERM, what schedulers and
``timeout`` send) would end the process on the spot.  Inside :func:`sigterm_interrupts` it
raises :class:`Terminated` instead, a KeyboardInterrupt, so every writer's cleanup runs the
same way for both, and the command can exit with the shell's convention for the signal:
130 (128 + SIGINT) after Ctrl-C, 143 (128 + SIGTERM) after SIGTERM.
"""

from __future__ import annotations

import contextlib
import signal
import threading

#: Exit statuses of a command a signal stopped (the shell's 128 + signal number).
INTERRUPTED = 128 + int(signal.SIGINT)
TERMINATED = 128 + int(signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM stopped the work: the same clean, resumable stop as Ctrl-C (a
    KeyboardInterrupt), told apart so that a command can exit with 128 + SIGTERM."""

    signum = signal.SIGTERM


@contextlib.contextmanager
def sigterm_interrupts():
    """While the block runs in the main thread, SIGTERM raises :class:`Terminated`.

    Nested uses are harmless (the innermost handler raises the same exception).  Library code
    that turns the interrupt into another KeyboardInterrupt on its way out is corrected: the
    exception that leaves the block is a :class:`Terminated` whenever SIGTERM arrived.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received = []

    def interrupt(signum, frame):
        received.append(signum)
        raise Terminated

    old = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    except KeyboardInterrupt as exc:
        if received and not isinstance(exc, Terminated):
            raise Terminated from exc
        raise
    finally:
        signal.signal(signal.SIGTERM, old)
