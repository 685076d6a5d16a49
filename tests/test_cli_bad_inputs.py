"""A fixed list of bad (and borderline) command lines, each with its expected outcome.

Every case must end either in a valid result (exit 0; JSON that parses strictly with
``--json``; no NaN printed) or in a short, clear error (exit != 0, at most
three lines on stderr, no traceback).  The test runs each case in-process through
``bbdyn.commands.cli.main``; run this file as a script to tally the outcomes of every case in
fresh processes (with a time limit, so hangs are counted), for example on an older
checkout::

    PYTHONPATH=/tmp/bbdyn_before python tests/test_cli_bad_inputs.py
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

#: Expected outcomes.
ERROR, RESULT = "error", "result"

SIM = ["--n", "4", "--t", "1"]  # tiny runs: a case costs well under a second
CL = ["classify", "--f", "85.2", "--n", "4", "--t", "2"]
BENCH = ["bench", "flat", "--quick", "--impacts", "2", "--long-run", "50"]  # a valid small run
LY = ["--n", "2", "--t", "0.3", "--transient", "0.1"]
STEEP = ["--n", "40", "--t", "1", "--R", "1.001"]
SCAN = ["scan", "--f-start", "60", "--f-stop", "60", *SIM, "--out", "{tmp}/scan"]
GK_F1 = repr(math.sqrt(9800.0 / 0.1) / (2 * math.pi))  # Gamma = 1 exactly, at the defaults

#: (name, argv, expected outcome); "{tmp}" is replaced by a fresh temporary folder.
CASES: list[tuple[str, list[str], str]] = [
    # ---- top level
    ("no-command", [], ERROR),
    ("unknown-command", ["frobnicate"], ERROR),
    ("version", ["--version"], RESULT),
    # ---- simulate
    ("sim-f-word", ["simulate", "--f", "abc", *SIM], ERROR),
    ("sim-f-nan", ["simulate", "--f", "nan", *SIM], ERROR),
    ("sim-f-inf", ["simulate", "--f", "inf", *SIM], ERROR),
    ("sim-f-negative", ["simulate", "--f", "-1", *SIM], ERROR),
    ("sim-f-zero", ["simulate", "--f", "0", *SIM], ERROR),
    ("sim-f-1e300", ["simulate", "--f", "1e300", *SIM], ERROR),
    ("sim-f-denormal", ["simulate", "--f", "5e-324", *SIM], ERROR),
    ("sim-f-missing", ["simulate", *SIM], ERROR),
    ("sim-gamma-below-1", ["simulate", "--f", "45", *SIM], RESULT),
    ("sim-gamma-1", ["simulate", "--f", GK_F1, *SIM, "--json"], RESULT),
    ("sim-n-0", ["simulate", "--f", "85.2", "--n", "0", "--t", "1"], ERROR),
    ("sim-n-1", ["simulate", "--f", "85.2", "--n", "1", "--t", "1"], ERROR),
    ("sim-n-negative", ["simulate", "--f", "85.2", "--n", "-5", "--t", "1"], ERROR),
    ("sim-n-float", ["simulate", "--f", "85.2", "--n", "2.5", "--t", "1"], ERROR),
    ("sim-n-1e12", ["simulate", "--f", "85.2", "--n", "1000000000000", "--t", "1"], ERROR),
    ("sim-t-zero", ["simulate", "--f", "85.2", "--n", "4", "--t", "0"], ERROR),
    ("sim-t-negative", ["simulate", "--f", "85.2", "--n", "4", "--t", "-1"], ERROR),
    ("sim-t-nan", ["simulate", "--f", "85.2", "--n", "4", "--t", "nan"], ERROR),
    ("sim-t-inf", ["simulate", "--f", "85.2", "--n", "4", "--t", "inf"], ERROR),
    ("sim-t-below-period", ["simulate", "--f", "85.2", "--n", "4", "--t", "0.001"], ERROR),
    ("sim-t-1e12", ["simulate", "--f", "85.2", "--n", "4", "--t", "1e12"], ERROR),
    ("sim-seed-negative", ["simulate", "--f", "85.2", *SIM, "--seed", "-1"], ERROR),
    ("sim-seed-float", ["simulate", "--f", "85.2", *SIM, "--seed", "1.5"], ERROR),
    ("sim-seed-huge", ["simulate", "--f", "85.2", *SIM, "--seed", str(10**30)], RESULT),
    ("sim-transient-negative", ["simulate", "--f", "85.2", *SIM, "--transient", "-1"], ERROR),
    ("sim-transient-beyond-t", ["simulate", "--f", "85.2", *SIM, "--transient", "5"], ERROR),
    ("sim-transient-nan", ["simulate", "--f", "85.2", *SIM, "--transient", "nan"], ERROR),
    ("sim-threads-0", ["simulate", "--f", "85.2", *SIM, "--threads", "0"], ERROR),
    ("sim-threads-1000", ["simulate", "--f", "85.2", *SIM, "--threads", "1000"], ERROR),
    ("sim-A-negative", ["simulate", "--f", "85.2", *SIM, "--A", "-1"], ERROR),
    ("sim-A-1e300", ["simulate", "--f", "85.2", *SIM, "--A", "1e300"], ERROR),
    ("sim-A-nan", ["simulate", "--f", "85.2", *SIM, "--A", "nan"], ERROR),
    ("sim-A-zero", ["simulate", "--f", "85.2", *SIM, "--A", "0", "--json"], RESULT),
    ("sim-alpha-2", ["simulate", "--f", "85.2", *SIM, "--alpha", "2"], ERROR),
    ("sim-alpha-negative", ["simulate", "--f", "85.2", *SIM, "--alpha", "-0.5"], ERROR),
    ("sim-beta-1", ["simulate", "--f", "85.2", *SIM, "--beta", "1"], ERROR),
    ("sim-beta-1.5", ["simulate", "--f", "85.2", *SIM, "--beta", "1.5"], ERROR),
    ("sim-save-under-file", ["simulate", "--f", "85.2", *SIM, "--save", "/dev/null/x"], ERROR),
    ("sim-save-missing-folder", ["simulate", "--f", "85.2", *SIM, "--save", "{tmp}/no/x"], ERROR),
    ("sim-save-proc", ["simulate", "--f", "85.2", *SIM, "--save", "/proc/bbdyn_x"], ERROR),
    ("sim-save-ok", ["simulate", "--f", "85.2", *SIM, "--save", "{tmp}/x", "--json"], RESULT),
    ("sim-extra-positional", ["simulate", "--f", "85.2", *SIM, "extra"], ERROR),
    ("sim-unknown-option", ["simulate", "--f", "85.2", *SIM, "--frobnicate", "1"], ERROR),
    ("sim-json", ["simulate", "--f", "85.2", *SIM, "--json"], RESULT),
    # ---- gk
    ("gk-gamma-below-1", ["gk", "--f", "45", *SIM, "--json"], RESULT),
    ("gk-gamma-below-1-text", ["gk", "--f", "45", *SIM], RESULT),
    ("gk-gamma-1", ["gk", "--f", GK_F1, *SIM, "--json"], RESULT),
    ("gk-f-negative", ["gk", "--f", "-1", *SIM], ERROR),
    ("gk-f-nan", ["gk", "--f", "nan", *SIM], ERROR),
    ("gk-nmax-0", ["gk", "--f", "85.2", *SIM, "--nmax", "0"], ERROR),
    ("gk-nmax-negative", ["gk", "--f", "85.2", *SIM, "--nmax", "-1"], ERROR),
    ("gk-nmax-10000", ["gk", "--f", "85.2", *SIM, "--nmax", "10000"], ERROR),
    ("gk-nmax-1e11", ["gk", "--f", "85.2", *SIM, "--nmax", "100000000000"], ERROR),
    ("gk-n-0", ["gk", "--f", "85.2", "--n", "0", "--t", "1"], ERROR),
    ("gk-n-1", ["gk", "--f", "85.2", "--n", "1", "--t", "1"], ERROR),
    ("gk-t-zero", ["gk", "--f", "85.2", "--n", "4", "--t", "0"], ERROR),
    ("gk-t-nan", ["gk", "--f", "85.2", "--n", "4", "--t", "nan"], ERROR),
    ("gk-seed-negative", ["gk", "--f", "85.2", *SIM, "--seed", "-1"], ERROR),
    ("gk-threads-0", ["gk", "--f", "85.2", *SIM, "--threads", "0"], ERROR),
    ("gk-save-under-file", ["gk", "--f", "85.2", *SIM, "--save", "/dev/null/x"], ERROR),
    ("gk-save-missing-folder", ["gk", "--f", "85.2", *SIM, "--save", "{tmp}/no/x"], ERROR),
    ("gk-json", ["gk", "--f", "85.2", *SIM, "--nmax", "3", "--json"], RESULT),
    # ---- tongues
    ("tongues-kmax-0", ["tongues", "--kmax", "0"], ERROR),
    ("tongues-kmax-negative", ["tongues", "--kmax", "-1"], ERROR),
    ("tongues-kmax-1e11", ["tongues", "--kmax", "100000000000"], ERROR),
    ("tongues-kmax-float", ["tongues", "--kmax", "2.5"], ERROR),
    ("tongues-alpha-negative", ["tongues", "--alpha", "-0.1"], ERROR),
    ("tongues-alpha-1.5", ["tongues", "--alpha", "1.5"], ERROR),
    ("tongues-alpha-nan", ["tongues", "--alpha", "nan"], ERROR),
    ("tongues-alpha-0", ["tongues", "--alpha", "0", "--json"], RESULT),
    ("tongues-alpha-1", ["tongues", "--alpha", "1", "--kmax", "2", "--json"], RESULT),
    ("tongues-alpha-tiny", ["tongues", "--alpha", "1e-9", "--kmax", "1"], ERROR),
    ("tongues-alpha-tiny-closed-form", ["tongues", "--alpha", "1e-9", "--closed-form"], RESULT),
    ("tongues-A-0", ["tongues", "--A", "0"], ERROR),
    ("tongues-A-negative", ["tongues", "--A", "-1"], ERROR),
    ("tongues-A-1e300", ["tongues", "--A", "1e300"], ERROR),
    ("tongues-A-nan", ["tongues", "--A", "nan"], ERROR),
    ("tongues-g-0", ["tongues", "--g", "0"], ERROR),
    ("tongues-g-negative", ["tongues", "--g", "-1"], ERROR),
    ("tongues-g-1e300", ["tongues", "--g", "1e300"], ERROR),
    ("tongues-json", ["tongues", "--kmax", "2", "--json"], RESULT),
    ("tongues-text", ["tongues", "--kmax", "2"], RESULT),
    # ---- classify
    ("classify-f-missing", ["classify", "--n", "4", "--t", "2"], ERROR),
    ("classify-f-negative", ["classify", "--f", "-1", "--n", "4", "--t", "2"], ERROR),
    ("classify-f-nan", ["classify", "--f", "nan", "--n", "4", "--t", "2"], ERROR),
    ("classify-n-0", ["classify", "--f", "85.2", "--n", "0", "--t", "2"], ERROR),
    ("classify-n-1", ["classify", "--f", "85.2", "--n", "1", "--t", "2"], ERROR),
    ("classify-t-zero", ["classify", "--f", "85.2", "--n", "4", "--t", "0"], ERROR),
    ("classify-seed-negative", [*CL, "--seed", "-1"], ERROR),
    ("classify-transient-beyond-t", [*CL, "--transient", "5"], ERROR),
    ("classify-box-word", [*CL, "--box", "huge"], ERROR),
    ("classify-box-three", [*CL, "--box", "1,2,3"], ERROR),
    ("classify-box-s-outside", [*CL, "--box", "5,6,0,1,0,1"], ERROR),
    ("classify-box-into-floor", [*CL, "--box", "0,1,-1,1,-100,-60"], ERROR),
    # vy+ < 0 but above the floor's velocity -A w = -53.5 mm/s at t = 0: it leaves the floor
    ("classify-box-floor-falls-faster", [*CL, "--box", "0,1,-1,1,-5,-1", "--json"], RESULT),
    ("classify-box-nan", [*CL, "--box", "0,1,nan,1,0,1"], ERROR),
    ("classify-R-half-d", [*CL, "--R", "1"], ERROR),
    ("classify-R-below-half-d", [*CL, "--R", "0.5"], ERROR),
    ("classify-R-1e300", [*CL, "--R", "1e300"], ERROR),
    ("classify-R-nan", [*CL, "--R", "nan"], ERROR),
    ("classify-plot-missing-folder", [*CL, "--plot", "{tmp}/no/x.png"], ERROR),
    ("classify-plot-under-file", [*CL, "--plot", "/dev/null/x.png"], ERROR),
    ("classify-gamma-below-1", ["classify", "--f", "45", "--n", "4", "--t", "2", "--json"], RESULT),
    # ---- bench
    ("bench-no-target", ["bench"], ERROR),
    ("bench-bad-target", ["bench", "nosuch"], ERROR),
    ("bench-impacts-0", ["bench", "flat", "--quick", "--impacts", "0"], ERROR),
    ("bench-impacts-negative", ["bench", "flat", "--quick", "--impacts", "-1"], ERROR),
    ("bench-long-run-0", ["bench", "flat", "--quick", "--long-run", "0"], ERROR),
    ("bench-impacts-1e12", ["bench", "flat", "--quick", "--impacts", "1000000000000"], ERROR),
    ("bench-out-missing-folder", [*BENCH, "--out", "{tmp}/no/b.png"], ERROR),
    ("bench-out-under-file", [*BENCH, "--out", "/dev/null/b.png"], ERROR),
    ("bench-out-proc", [*BENCH, "--out", "/proc/bbdyn_b.png"], ERROR),
    # ---- sizes are checked before the initial conditions are drawn
    ("classify-n-1e9", ["classify", "--f", "85.2", "--n", "1000000000", "--t", "1"], ERROR),
    # ---- steep wedges, R = 1.001 d/2: the default box draws states that leave the floor
    # (40 particles: about 8 % of the box's states move into the arc there)
    ("sim-R-steep", ["simulate", "--f", "85.2", *STEEP, "--json"], RESULT),
    ("gk-R-steep", ["gk", "--f", "85.2", *STEEP, "--json"], RESULT),
    ("classify-R-steep", ["classify", "--f", "85.2", *STEEP, "--t", "2", "--json"], RESULT),
    ("lyapunov-R-steep", ["lyapunov", "--f", "85.2", *LY, "--n", "40", "--R", "1.001"], RESULT),
    ("scan-R-steep", [*SCAN, *STEEP, "--workers", "1", "--json"], RESULT),
    # ---- nothing moves (A = 0): r = E_y / E_x is 0 / 0, D_a undefined with its reason
    ("gk-A-0", ["gk", "--f", "85.2", *SIM, "--A", "0", "--json"], RESULT),
    ("gk-A-0-text", ["gk", "--f", "85.2", *SIM, "--A", "0"], RESULT),
    # ---- lyapunov: windows shorter than a driving period measure nothing
    ("lyapunov-t-1e-300", ["lyapunov", "--f", "85.2", "--n", "2", "--t", "1e-300"], ERROR),
    ("lyapunov-t-below-windows", ["lyapunov", "--f", "85.2", "--n", "2", "--t", "0.04"], ERROR),
    ("lyapunov-flat-t-1e-300", ["lyapunov", "--flat", "--f", "85.2", "--t", "1e-300"], ERROR),
    ("lyapunov-flat-spectrum", ["lyapunov", "--flat", "--f", "85.2", *LY, "--spectrum"], ERROR),
    ("lyapunov-qr-every-0", ["lyapunov", "--f", "85.2", *LY, "--spectrum", "--qr-every", "0"],
     ERROR),
    # ---- output paths: never empty, the same for every command
    ("scan-out-empty", ["scan", "--f-start", "60", "--f-stop", "60", *SIM, "--out", ""], ERROR),
    ("scene-out-empty", ["scene", "S1", "--out", ""], ERROR),
    ("reproduce-out-empty", ["reproduce", "--only", "S1", "--out", ""], ERROR),
    ("scan-progress-empty", [*SCAN, "--progress", ""], ERROR),
    ("scan-progress-missing-folder", [*SCAN, "--progress", "{tmp}/no/log"], ERROR),
    ("scan-resume-nothing", [*SCAN, "--resume"], ERROR),
]

#: Outcome categories of the tally, in print order.
CATEGORIES = (
    "clear error",
    "verbose error",
    "valid result",
    "refused valid input",
    "traceback",
    "hang",
    "silent garbage",
)

TIME_LIMIT_S = 60.0  # a case running longer counts as a hang
TRACEBACK_MARKS = ("Traceback (most recent call last)", "Exception ignored", "During: ")
#: NaN in text output is an undefined number printed as if it were one ("undefined" is the
#: word for it); inf may be a true value (tau when nothing jumps).
NOT_A_NUMBER = re.compile(r"\bnan\b", re.IGNORECASE)


def strict_json(text: str):
    """Parse JSON refusing NaN and Infinity (not JSON, though Python writes them)."""

    def refuse(token):
        raise ValueError(f"non-finite number {token} in the JSON output")

    return json.loads(text, parse_constant=refuse)


def classify_outcome(argv: list[str], expected: str, code: int, out: str, err: str) -> str:
    """One of ``CATEGORIES`` (but "hang") for a finished run."""
    if any(mark in err for mark in TRACEBACK_MARKS):
        return "traceback"
    if code != 0:
        if expected == RESULT:
            return "refused valid input"
        lines = err.strip().splitlines()
        return "clear error" if 1 <= len(lines) <= 3 else "verbose error"
    if expected == ERROR or not out.strip():
        return "silent garbage"
    if "--json" in argv:
        try:
            strict_json(out)
        except ValueError:
            return "silent garbage"
    elif NOT_A_NUMBER.search(out):
        return "silent garbage"
    return "valid result"


def run_main(argv: list[str]) -> int:
    """Exit status of ``bbdyn.commands.cli.main(argv)``: its return value or its SystemExit code."""
    from bbdyn.commands.cli import main

    try:
        return main(argv)
    except SystemExit as done:
        return done.code


def fill(argv: list[str], tmp: Path) -> list[str]:
    """``argv`` with "{tmp}" replaced by the folder ``tmp``."""
    return [a.replace("{tmp}", str(tmp)) for a in argv]


@pytest.mark.parametrize(("argv", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_gives_a_clear_error_or_a_valid_result(
    argv, expected, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)  # an empty output path must not write into the checkout
    argv = fill(argv, tmp_path)
    code = run_main(argv)
    out, err = capsys.readouterr()
    outcome = classify_outcome(argv, expected, code, out, err)
    want = "clear error" if expected == ERROR else "valid result"
    assert outcome == want, f"{argv}: exit {code}\nstdout: {out[-2000:]}\nstderr: {err[-2000:]}"
    assert not (tmp_path / "no").exists(), "a missing output folder must not be created"


def run_case(argv: list[str], expected: str, tmp: Path) -> str:
    """Run one case in a fresh ``python -m bbdyn.commands.cli`` process; its outcome category."""
    cmd = [sys.executable, "-m", "bbdyn.commands.cli", *fill(argv, tmp)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=TIME_LIMIT_S)
    except subprocess.TimeoutExpired:
        return "hang"
    return classify_outcome(argv, expected, proc.returncode, proc.stdout, proc.stderr)


def run_broken_pipe() -> str:
    """``bbdyn tongues --json | head -c 0``: the reader has gone before the first write."""
    cmd = [sys.executable, "-m", "bbdyn.commands.cli", "tongues", "--kmax", "2", "--json"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()
    try:
        _, err = proc.communicate(timeout=TIME_LIMIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        return "hang"
    return "traceback" if any(m in err for m in TRACEBACK_MARKS) else "valid result"


def tally() -> dict[str, list[str]]:
    """Outcome category -> names of the cases that ended in it (every case, plus the pipe)."""
    found: dict[str, list[str]] = {c: [] for c in CATEGORIES}
    for name, argv, expected in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            outcome = run_case(argv, expected, Path(tmp))
        found[outcome].append(name)
        print(f"{name:32} {outcome:15} {time.perf_counter() - start:6.1f} s", flush=True)
    found[run_broken_pipe()].append("tongues-json-broken-pipe")
    return found


if __name__ == "__main__":
    result = tally()
    print(f"tried {sum(len(v) for v in result.values())}")
    for category in CATEGORIES:
        print(f"{category:15} {len(result[category]):4}  {' '.join(result[category])}")
