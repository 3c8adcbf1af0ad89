"""``rcsim`` command line: a thin parser that hands a config to library functions.

Each command lives in its own module exposing ``register(subparsers)``; the parser it adds
sets ``func(args) -> int``.  CLI modules parse arguments and report errors; the work is done
by library functions that tests import.

User mistakes print one line on stderr and exit with code 2, never a traceback:

* :class:`~rcsim.models.errors.InputError` -- a library error about one of its parameters
  (``parameter="runs"``) is shown under the flag or argument that fills it (``--runs``);
* ``OSError`` on a user's path (permission, read-only or full filesystem, ``/proc``) -- the
  path and the system's reason;
* argparse errors (unknown option, bad number).

A closed stdout (``rcsim ... | head``) ends the command quietly with status 141, as a process
that SIGPIPE ended (a campaign prints its summary once its directory is written, so it is
complete then).

The CLI writes files only, so it selects matplotlib's file backend (Agg) before any command
runs; library plotting modules never choose a backend (that would switch a notebook's).

Owns nothing a library needs: no module outside the CLI imports it.

Only imported by: rcsim.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import threading

from rcsim.models.errors import InputError

# Every command group's module, in the order ``rcsim --help`` lists them.
_COMMANDS = (
    "rcsim.analysis.apps.cli.loop",
    "rcsim.analysis.apps.cli.maneuver",
    "rcsim.analysis.apps.cli.lookup",
    "rcsim.analysis.apps.cli.scenario",
    "rcsim.analysis.apps.cli.campaign",
    "rcsim.analysis.apps.cli.study",
    "rcsim.analysis.apps.cli.analyze",
    "rcsim.analysis.apps.cli.compare",
    "rcsim.analysis.apps.cli.vehicle",
)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and raise instead of exiting."""

    def error(self, message: str):  # noqa: D401 - argparse API
        # "rcsim: error: maneuver: argument --duration-s: ...", not "rcsim: error: rcsim ...".
        command = self.prog.partition(" ")[2]
        raise InputError(f"{command}: {message}" if command else message)


def _leaf_parsers(parser: argparse.ArgumentParser):
    """Every parser that runs a command (has a ``func`` default), depth first."""
    # argparse exposes sub-parsers only through these long-stable private attributes.
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):  # aliases share a parser
                yield from _leaf_parsers(child)
    if parser.get_default("func") is not None:
        yield parser


def _version() -> str:
    """The installed rcsim's version (``rcsim.__version__``, read from the package metadata:
    the CLI sits below ``rcsim`` and does not import it)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rcsim")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "(not installed)"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rcsim",
        description="Spacecraft reaction-control simulation in MuJoCo: on/off jets, any "
        "number (a vehicle file's; the paper's vehicle has 16).",
    )
    parser.add_argument("--version", action="version", version=f"rcsim {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in _COMMANDS:
        importlib.import_module(name).register(sub)
    for leaf in _leaf_parsers(parser):
        leaf.set_defaults(_parser=leaf)  # so that errors can name this command's flags
    return parser


def argument_name(parser: argparse.ArgumentParser | None, parameter: str) -> str:
    """How ``parser``'s command line spells library parameter ``parameter``.

    The flag whose destination is ``parameter`` (``runs`` -> ``--runs``), a positional
    argument's metavar (``run_id`` -> ``RUN_ID``), else the parameter's own name.
    """
    for action in parser._actions if parser is not None else ():
        if action.dest != parameter:
            continue
        if action.option_strings:
            return max(action.option_strings, key=len)
        metavar = action.metavar
        return metavar if isinstance(metavar, str) else parameter.upper()
    return parameter


def error_line(exc: BaseException, parser: argparse.ArgumentParser | None = None) -> str:
    """The one line reported for a user error (without the ``rcsim: error:`` prefix)."""
    from rcsim.analysis.engine.output import OutputExists

    if isinstance(exc, OutputExists):
        flag = argument_name(parser, exc.parameter or "out")
        if argument_name(parser, "overwrite") == "overwrite":  # this command never replaces
            return f"{flag} {exc.path}: {exc.what}; choose another path"
        return (
            f"{flag} {exc.path}: {exc.what}; use --overwrite to replace it, or choose another path"
        )
    if isinstance(exc, InputError):
        if exc.parameter is None:
            return str(exc)
        return exc.render(argument_name(parser, exc.parameter))
    if isinstance(exc, OSError):
        paths = " -> ".join(str(p) for p in (exc.filename, exc.filename2) if p is not None)
        reason = exc.strerror or str(exc)
        return f"{paths}: {reason}" if paths else reason
    return str(exc)


def _use_file_backend() -> None:
    """Agg: the CLI only writes image files and must work without a display."""
    import matplotlib

    matplotlib.use("Agg")


def main(argv: list[str] | None = None) -> int:
    from rcsim.analysis.engine.interrupts import (
        INTERRUPTED,
        TERMINATED,
        Terminated,
        sigterm_interrupts,
    )
    from rcsim.analysis.engine.locks import claim_scope

    parser = build_parser()
    args = None
    claims = None
    try:
        # SIGTERM stops every command as Ctrl-C does (cleanly, resumably), told apart by the
        # exit status: 143 against 130.  Every output a command checks is locked from that
        # check, before its work, to its end (rcsim.analysis.engine.locks).
        with sigterm_interrupts(), claim_scope() as claims:
            args = parser.parse_args(argv)
            claims.command = args._parser.prog.partition(" ")[2]  # "lookup refine"
            _use_file_backend()
            return int(args.func(args) or 0)
    except (InputError, OSError) as exc:
        if isinstance(exc, BrokenPipeError) and _stdout_closed():
            # `rcsim ... | head`: the reader has gone.  End quietly, as other command-line
            # tools do (killed by SIGPIPE: status 128 + 13); nothing to report to anyone.
            return STDOUT_CLOSED
        if isinstance(exc, OSError) and claims is not None:
            exc = _name_outputs(exc, claims.outputs)
        # One line even if a message carries a newline (a path, a parser's text).
        line = " ".join(error_line(exc, getattr(args, "_parser", None)).split("\n"))
        print(f"rcsim: error: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        what, code = (
            ("terminated", TERMINATED)
            if isinstance(exc, Terminated)
            else ("interrupted", INTERRUPTED)
        )
        hint = getattr(args, "resume_hint", None)
        print(f"rcsim: {what}" + (f"; resume with: {hint(args)}" if hint else ""), file=sys.stderr)
        return code


def _name_outputs(exc: OSError, outputs: list) -> OSError:
    """A write error that names no file (a full disk met by a library that does not say
    where) names the command's outputs instead: every write goes to one of them."""
    from rcsim.models.atomic import WRITE_ERRNOS, named_os_error, os_errno

    if exc.filename is not None or not outputs or os_errno(exc) not in WRITE_ERRNOS:
        return exc
    return named_os_error(exc, "writing " + ", ".join(str(p) for p in outputs))


#: Seconds the interpreter may take to exit after an interrupt before the process ends anyway
#: (every cleanup of rcsim's own is done by then; a normal exit takes about 1 s).
EXIT_GRACE_S = 3.0
#: Exit status when stdout was closed by its reader (``| head``): a shell's for a process that
#: SIGPIPE ended, 128 + 13.
STDOUT_CLOSED = 141


def _stdout_closed() -> bool:
    """Whether stdout is a pipe whose reader has gone, as opposed to a broken pipe of some
    other file, which is reported.  Asked of the descriptor (poll: POLLERR on a pipe with no
    reader), since Python's buffer drops what a failed write held, so a second flush succeeds.
    """
    import select

    try:
        fd = sys.stdout.fileno()
        poller = select.poll()
        poller.register(fd, select.POLLOUT)
        events = poller.poll(0)
    except (AttributeError, OSError, ValueError):  # no descriptor (captured), or no poll
        return False
    return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in events)


def _silence_stderr() -> None:
    """After an interrupt's one line, this process says nothing more: what libraries print
    while the interpreter exits (an exit hook's traceback of a Dask cluster interrupted while
    it started, asyncio's "Task exception was never retrieved", a pool's warnings) goes to
    /dev/null.  Everything rcsim had to do and say is done when :func:`main` returns."""
    try:
        sys.stderr.flush()
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stderr.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass  # no descriptor (a captured stream): nothing to protect


def run() -> None:
    """The ``rcsim`` command: :func:`main`, then exit with its status.

    After Ctrl-C or SIGTERM the stop is guaranteed: every cleanup has run by the time
    :func:`main` returns, but CPython's exit hook for process pools joins a pool's manager
    thread with no timeout, and a killed pool's manager was seen to hang there once in CI
    (the one line printed, then no exit for over a minute).  A daemon timer ends the process
    with the same status if the interpreter has not exited within :data:`EXIT_GRACE_S`.
    (Only here, never in :func:`main`, which tests and notebooks call in their own process.)
    """
    code = main()
    if code != STDOUT_CLOSED:
        try:  # what is still buffered goes now, not in the interpreter's exit hook
            sys.stdout.flush()
        except BrokenPipeError:
            code = STDOUT_CLOSED
    if code == STDOUT_CLOSED:
        # Python flushes stdout again at exit and would print its own broken-pipe complaint:
        # point the closed descriptor at /dev/null first.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    from rcsim.analysis.engine.interrupts import INTERRUPTED, TERMINATED

    if code in (INTERRUPTED, TERMINATED):
        _silence_stderr()

        def end(status: int = code) -> None:
            for stream in (sys.stderr, sys.stdout):
                try:
                    stream.flush()
                except (OSError, ValueError):
                    pass
            os._exit(status)

        timer = threading.Timer(EXIT_GRACE_S, end)
        timer.daemon = True
        timer.start()
    sys.exit(code)


if __name__ == "__main__":
    run()
