"""``rcsim`` command line: a thin parser that hands a config to library functions.

Each command lives in its own module exposing ``register(subparsers)``; the parser it adds
sets ``func(args) -> int``.  User mistakes (:class:`models.errors.InputError`, argparse
errors) print one line on stderr and exit with code 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from rcsim.models.errors import InputError

# Every command group's module, in the order ``rcsim --help`` lists them.
_COMMANDS = (
    "rcsim.analysis.cli.maneuver",
    "rcsim.analysis.cli.lookup",
    "rcsim.analysis.cli.scenario",
    "rcsim.analysis.cli.campaign",
    "rcsim.analysis.cli.study",
)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and raise instead of exiting."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(f"{self.prog}: {message}")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rcsim",
        description="Spacecraft reaction-control simulation (16 on/off jets, MuJoCo).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in _COMMANDS:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"rcsim: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("rcsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
