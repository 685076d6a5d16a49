"""The ``bbdyn`` command line.

Each subcommand lives in its own module under ``bbdyn.commands`` and exposes
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.  The
modules import heavy dependencies (matplotlib, sympy, scipy) inside ``run``, so
``bbdyn --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: subcommand name -> module under bbdyn.commands
COMMANDS = {
    "tongues": "tongues",
    "scene": "scene",
    "bench": "bench",
    "simulate": "simulate",
    "reproduce": "reproduce",
    "gk": "gk",
    "scan": "scan",
    "classify": "classify",
}


def build_parser() -> argparse.ArgumentParser:
    from bbdyn import __version__

    parser = argparse.ArgumentParser(
        prog="bbdyn", description="Exact dynamics of the bouncing ball billiard."
    )
    parser.add_argument("--version", action="version", version=f"bbdyn {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"bbdyn.commands.{module_name}")
        cmd = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(cmd)
        cmd.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``bbdyn`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except ValueError as err:
        parser.exit(2, f"bbdyn {args.command}: error: {err}\n")
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
