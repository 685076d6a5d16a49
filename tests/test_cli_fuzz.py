"""Fuzz test of the command line: random argument lists for every subcommand.

Each argument list mixes valid and invalid values (huge, tiny, negative, NaN, inf,
words, empty), missing and extra arguments and bad output paths, and runs in-process
through ``bbdyn.commands.cli.main``.  It must either succeed (exit 0 with output; JSON that
parses strictly with ``--json``) or fail with a short message (exit != 0, at most three
lines on stderr naming the error, never a traceback).  Valid runs are kept tiny (at
most 5 particles for at most 2 s; huge n and t only where they are refused), and the
expensive commands (bench, scene, reproduce, scan) always get at least one invalid
argument, so the whole file runs in about a minute.  Derandomized by the project's
hypothesis profile (tests/conftest.py).
"""

from __future__ import annotations

import math
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from io import StringIO
from pathlib import Path

from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from test_cli_bad_inputs import fill, run_main, strict_json

#: Commands whose successful runs print a JSON document with --json.
JSON_COMMANDS = {"simulate", "gk", "tongues", "classify", "bench", "scan"}
F_GAMMA_ONE = repr(math.sqrt(9800.0 / 0.1) / (2 * math.pi))

BAD = ["nan", "inf", "-inf", "1e999", "abc", "", "-1", "0", "1e300", "-1e300", "5e-324", "0x10"]
PATHS = ["{tmp}/x", "{tmp}/no/x", "/dev/null/x", "{tmp}", "", "/proc/bbdyn_fuzz", "{tmp}/a b"]
PNGS = ["{tmp}/p.png", "{tmp}/no/p.png", "/dev/null/p.png", "{tmp}"]


def tokens(*values: str) -> st.SearchStrategy[str]:
    return st.sampled_from(values)


def numbers(low: float, high: float) -> st.SearchStrategy[str]:
    """Any float in [low, high] as text."""
    return st.floats(low, high).map(repr)


def wild() -> st.SearchStrategy[str]:
    """A bad value: a fixed list of troublemakers, any float at all, or short text."""
    return st.one_of(
        tokens(*BAD),
        st.floats().map(repr),
        st.integers(-(10**20), 10**20).map(str),
        st.text(max_size=4),
    )


def option(good, bad=None) -> tuple:
    """An option's (valid, invalid) value strategies; ``None`` marks a flag."""
    return good, wild() if bad is None else bad


#: Sizes: tiny valid values, or values that are refused (never a long run).
N = option(tokens("2", "3", "5"), tokens("0", "1", "-5", "2.5", "1000000000000", "x", ""))
T = option(numbers(0.05, 2.0), tokens("0", "-1", "nan", "inf", "1e12", "1e300", "x", "0.001"))
F = option(st.one_of(tokens("45", "58", "85.2", F_GAMMA_ONE, "1000"), numbers(1.0, 2000.0)))
FLAG = (None, None)
ENSEMBLE = {
    "--seed": option(tokens("0", "7", str(10**30)), tokens("-1", "1.5", "x", "")),
    "--threads": option(tokens("1"), tokens("0", "-1", "1000", "x")),
    "--json": FLAG,
}
SIZES = {"--n": N, "--t": T}  # always given: their defaults are long runs
ENSEMBLE_COMMANDS = ("simulate", "gk", "classify")
OPTIONS = {
    "simulate": {
        "--f": F,
        **ENSEMBLE,
        "--transient": option(numbers(0.0, 0.04)),
        "--A": option(numbers(0.0, 1.0)),
        "--alpha": option(numbers(0.0, 1.0)),
        "--beta": option(numbers(0.0, 0.999), tokens("1", "1.5", "-0.1", "nan")),
        "--save": option(tokens("{tmp}/x", "{tmp}/a b"), tokens(*PATHS[1:])),
    },
    "gk": {
        "--f": F,
        **ENSEMBLE,
        "--nmax": option(
            st.integers(1, 1000).map(str), tokens("0", "-1", "1001", "100000000000", "x")
        ),
        "--save": option(tokens("{tmp}/x"), tokens(*PATHS[1:])),
    },
    "tongues": {
        "--alpha": option(numbers(0.0, 1.0)),
        "--kmax": option(
            st.integers(1, 12).map(str), tokens("0", "-3", "1001", "100000000000", "2.5")
        ),
        "--A": option(numbers(0.01, 2.0)),
        "--g": option(tokens("9800", "1e-6", "1e12", "1000")),
        "--json": FLAG,
        "--closed-form": FLAG,
    },
    "classify": {
        **ENSEMBLE,
        "--transient": option(numbers(0.0, 0.04)),
        "--box": option(
            tokens("ref", "high", "0,1,-1,1,0,1", "0,1,-1,1,-5,-1"),
            tokens("huge", "1,2,3", "5,6,0,1,0,1", "0,1,nan,1,0,1", "0,1,-1,1,-100,-60"),
        ),
        "--R": option(tokens("25", "1e9", "1.5"), st.one_of(tokens("1", "0.5"), wild())),
        "--plot": option(tokens("{tmp}/p.png"), tokens(*PNGS[1:])),
    },
}
#: Required positionals and options, dropped now and then to test their absence.
REQUIRED = {"simulate": ["--f"], "gk": ["--f"]}
#: One argument list of each expensive command that is certainly refused.
REFUSED = {
    "bench": tokens(
        "nosuch", "flat --impacts 0", "billiard --impacts 100000000000", "flat --long-run -1",
        "flat --out {tmp}/no/b.png", "flat --out /dev/null/b.png", "flat --impacts x", "",
    ),
    "scene": tokens("S99", "", "S1 --seed x", "S1 --quick --full", "s99 --out {tmp}/o"),
    "reproduce": tokens("--only S99", "--only", "--quick --full", "--frobnicate"),
    "scan": tokens(
        "--out {tmp}/s --f-start nan", "--out {tmp}/s --n 1", "--out {tmp}/s --t 0",
        "--f-start 60 --f-stop 61", "--out {tmp}/s --f-step 0", "--out {tmp}/s --seed x",
    ),
}  # fmt: skip
EXTRA = tokens("extra", "--frobnicate", "-x", "--", "--json")


@st.composite
def command_lines(draw, command: str) -> list[str]:
    """An argument list of ``command``: the sizes, some options, up to two of the values
    invalid, now and then a required argument missing or an extra one."""
    sizes = SIZES if command in ENSEMBLE_COMMANDS else {}
    spec = {**sizes, **OPTIONS[command]}
    names = [n for n in spec if n in sizes or n in REQUIRED.get(command, []) or draw(st.booleans())]
    valued = [n for n in names if spec[n][0] is not None]
    bad = set(draw(st.lists(st.sampled_from(valued), max_size=2))) if valued else set()
    if draw(st.booleans()):  # half of the lines have only valid values
        bad = set()
    argv = [command]
    if command == "classify":
        argv += ["--f", draw(F[1] if "f" in bad or draw(st.integers(0, 9)) == 0 else F[0])]
    for name in names:
        good, wrong = spec[name]
        if good is None:
            argv.append(name)
        else:
            argv += [name, draw(wrong if name in bad else good)]
    if len(argv) > 1 and draw(st.integers(0, 9)) == 0:  # drop one (maybe a required one)
        del argv[draw(st.integers(1, len(argv) - 1))]
    if draw(st.integers(0, 9)) == 0:
        argv.append(draw(EXTRA))
    return argv


@st.composite
def refused_lines(draw, command: str) -> list[str]:
    return [command, *draw(REFUSED[command]).split()]


def check(argv: list[str]) -> None:
    """Run ``argv``: a valid result or a short error, never a traceback."""
    with tempfile.TemporaryDirectory() as tmp:
        argv = fill(argv, Path(tmp))
        out, err = StringIO(), StringIO()
        with redirect_stdout(out), redirect_stderr(err):
            code = run_main(argv)
        assert not (Path(tmp) / "no").exists(), "a missing output folder was created"
    out, err = out.getvalue(), err.getvalue()
    event(f"exit status {code}")  # shown by --hypothesis-show-statistics
    context = f"{argv}: exit {code}\nstdout: {out[-1500:]}\nstderr: {err[-1500:]}"
    assert "Traceback" not in err and "Exception ignored" not in err, context
    if code == 0:
        assert out.strip(), context
        if "--json" in argv and argv[0] in JSON_COMMANDS and "--help" not in argv:
            strict_json(out)
        return
    lines = err.strip().splitlines()
    assert 1 <= len(lines) <= 3, context
    said = [line for line in lines if ": note: " not in line]  # e.g. a deprecated form
    assert said and ("error" in said[0] or said[0] == "interrupted"), context


FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(command_lines("simulate"))
@example(["simulate", "--f", "1e300", "--n", "4", "--t", "1"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--A", "1e300"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--seed", "-1"])
@example(["simulate", "--f", "85.2", "--n", "0", "--t", "1"])
@example(["simulate", "--f", "85.2", "--n", "1", "--t", "1"])
@example(["simulate", "--f", "85.2", "--n", "1000000000000", "--t", "1"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1e12"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--save", "/dev/null/x"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--save", "{tmp}/no/x"])
@example(["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--save", "{tmp}/x", "--json"])
@example(["simulate", "--f", "45", "--n", "4", "--t", "1", "--json"])
def test_simulate(argv):
    check(argv)


@FUZZ
@given(command_lines("gk"))
@example(["gk", "--f", "45", "--n", "4", "--t", "1", "--json"])
@example(["gk", "--f", F_GAMMA_ONE, "--n", "4", "--t", "1"])
@example(["gk", "--f", "85.2", "--n", "4", "--t", "1", "--nmax", "10000"])
@example(["gk", "--f", "85.2", "--n", "4", "--t", "1", "--nmax", "1000", "--json"])
@example(["gk", "--f", "85.2", "--n", "1", "--t", "1"])
@example(["gk", "--f", "85.2", "--n", "4", "--t", "1", "--seed", "-1"])
@example(["gk", "--f", "85.2", "--n", "4", "--t", "1", "--save", "{tmp}/no/x"])
def test_gk(argv):
    check(argv)


@FUZZ
@given(command_lines("tongues"))
@example(["tongues", "--kmax", "100000000000"])
@example(["tongues", "--kmax", "0"])
@example(["tongues", "--A", "1e300"])
@example(["tongues", "--g", "1e300"])
@example(["tongues", "--alpha", "0", "--json"])
@example(["tongues", "--alpha", "1e-9", "--kmax", "1"])
def test_tongues(argv):
    check(argv)


@FUZZ
@given(command_lines("classify"))
@example(["classify", "--f", "85.2", "--n", "4", "--t", "2", "--R", "1"])
@example(["classify", "--f", "85.2", "--n", "4", "--t", "2", "--R", "1e300"])
@example(["classify", "--f", "85.2", "--n", "1", "--t", "2"])
@example(["classify", "--f", "85.2", "--n", "4", "--t", "2", "--plot", "{tmp}/no/x.png"])
@example(["classify", "--f", "85.2", "--n", "4", "--t", "2", "--plot", "/dev/null/x.png"])
@example(["classify", "--f", "45", "--n", "4", "--t", "2", "--json"])
def test_classify(argv):
    check(argv)


@settings(FUZZ, max_examples=15)
@given(st.sampled_from(sorted(REFUSED)).flatmap(refused_lines))
@example(["bench", "flat", "--quick", "--impacts", "1000000000000"])
@example(["bench", "flat", "--quick", "--impacts", "2", "--long-run", "50", "--out", "{tmp}/no/b"])
def test_expensive_commands_refuse_bad_arguments(argv):
    check(argv)
