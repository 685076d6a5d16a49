"""The ``bbdyn`` command line.

Each subcommand lives in its own module under ``bbdyn.commands`` and exposes
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.  The
modules import heavy dependencies (matplotlib, sympy, scipy) inside ``run``, so
``bbdyn --help`` stays fast.

Every failure ends here, in ``main``, as an exit status and a message of at most
three lines on stderr that names the problem and says what to do (``explain``):
never a traceback, unless ``BBDYN_DEBUG=1`` asks for one.  Exit statuses: 0 done,
1 the run failed (output path, memory, simulation, a bug), 2 bad input, 130
interrupted (a command that keeps its work, as ``scan``, says what it kept and the command
that goes on: ``Interrupted``), 141 (128 + SIGPIPE) when the reader of stdout went away.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from bbdyn import __version__
from bbdyn.core.status import SimulationError
from bbdyn.gpu import NoDeviceError, cuda_device
from bbdyn.sources import refresh_kernel_caches

#: subcommand name -> module under bbdyn.commands
COMMANDS = {
    "tongues": "tongues",
    "scene": "scene",
    "bench": "bench",
    "simulate": "simulate",
    "reproduce": "reproduce",
    "gk": "gk",
    "correlations": "correlations",
    "scan": "scan",
    "classify": "classify",
    "doublings": "doublings",
    "lyapunov": "lyapunov",
}

EXIT_FAILED, EXIT_USAGE = 1, 2
EXIT_INTERRUPTED = 128 + signal.SIGINT
EXIT_BROKEN_PIPE = 128 + signal.SIGPIPE
DEBUG_VARIABLE = "BBDYN_DEBUG"


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM) in a command that says what it kept and how to go on: ``main``
    prints ``interrupted: MESSAGE`` instead of ``interrupted``."""


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are two lines (the error and where to read the usage),
    not the full usage block."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n{_see_help(self.prog)}\n")


def _see_help(prog: str) -> str:
    return f"run '{prog} --help' for the options and their defaults"


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="bbdyn", description="Exact dynamics of the bouncing ball billiard.")
    parser.add_argument("--version", action="version", version=f"bbdyn {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"bbdyn.commands.{module_name}")
        cmd = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(cmd)
        cmd.set_defaults(_run=module.run)
    return parser


def _settings(args) -> str:
    """The options of the command line as ``name=value`` (for failure messages)."""
    skip = {"command", "_run", "json"}
    if args is None:
        return "the command line"
    return " ".join(f"{k}={v}" for k, v in vars(args).items() if k not in skip and v is not None)


def _one_line(err: BaseException) -> str:
    """The exception's message on one line (a multi-line message joined with "; ")."""
    return "; ".join(line.strip() for line in str(err).splitlines() if line.strip())


def explain(err: BaseException, args) -> tuple[int, str]:
    """Exit status and message (at most three lines, no traceback) for an exception of a run."""
    prog = "bbdyn" if args is None else f"bbdyn {args.command}"
    text = _one_line(err)
    if isinstance(err, NoDeviceError):  # one line, which says what to do
        return EXIT_FAILED, text
    if isinstance(err, ValueError | TypeError):
        return EXIT_USAGE, f"{prog}: error: {text}\n{_see_help(prog)}"
    if isinstance(err, OSError):
        if not err.filename:  # not a path error: its message says what to do
            return EXIT_FAILED, f"{prog}: error: {text}"
        return EXIT_FAILED, (
            f"{prog}: error: {err.filename}: {err.strerror or text}\n"
            "check the path: its folder must exist and be writable, with free space on the disk"
        )
    if isinstance(err, MemoryError):
        return EXIT_FAILED, (
            f"{prog}: error: out of memory: {text or 'the run asked for more than is free'}\n"
            "reduce the sizes asked for (particles --n, time --t, orders --nmax/--kmax)"
        )
    if isinstance(err, OverflowError):
        return EXIT_USAGE, (
            f"{prog}: error: a number is too large ({text})\nuse smaller values; {_see_help(prog)}"
        )
    if isinstance(err, SimulationError):
        return EXIT_FAILED, (
            f"{prog}: error: the simulation failed: {text}\n"
            f"with {_settings(args)}\n"
            "try other parameters or a shorter run, and please report it with the command line"
        )
    return EXIT_FAILED, (
        f"{prog}: internal error: {type(err).__name__}: {text}\n"
        "this is a bug, please report it with the command line "
        f"(set {DEBUG_VARIABLE}=1 to see the traceback)"
    )


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so that the final flush of a closed pipe stays quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):  # stdout without a file descriptor
        pass


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``bbdyn`` console script.

    Returns the exit status of a command that completed.  Any failure prints its
    message (``explain``) and raises ``SystemExit`` with its status, as argparse
    does for usage errors.
    """
    args = None
    try:
        try:
            args = build_parser().parse_args(argv)
            if getattr(args, "device", "cpu") == "cuda":
                cuda_device()  # no GPU: one line, before anything is computed or written
            refresh_kernel_caches()  # kernels compiled from other source are not reused
            return int(args._run(args) or 0)
        finally:  # also after --help: a closed pipe fails here, not at interpreter exit
            sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
        raise SystemExit(EXIT_BROKEN_PIPE) from None
    except KeyboardInterrupt as err:
        said = f": {_one_line(err)}" if isinstance(err, Interrupted) else ""
        print(f"interrupted{said}", file=sys.stderr)
        raise SystemExit(EXIT_INTERRUPTED) from None
    except Exception as err:
        if os.environ.get(DEBUG_VARIABLE) == "1":
            raise
        status, message = explain(err, args)
        print(message, file=sys.stderr)
        raise SystemExit(status) from None


if __name__ == "__main__":
    sys.exit(main())
