"""One command line: every command takes the model parameters the same way, the same
quantity has the same JSON key and unit in every output, long runs show progress on a
terminal only, and ``python -m bbdyn`` is the ``bbdyn`` script."""

import argparse
import dataclasses
import io
import json
import math
import subprocess
import sys

import pytest

from bbdyn import Params, __version__
from bbdyn.commands import BILLIARD_OPTIONS, MODEL_MEANINGS, cli

#: Commands that run the billiard, and the model options each takes (scan scans f).
#: (lyapunov runs the billiard, or the flat ball with --flat, which needs --g; its tangent
#: dynamics is deterministic: no --eta.)
BILLIARD_COMMANDS = {"simulate": BILLIARD_OPTIONS, "gk": BILLIARD_OPTIONS,
                     "classify": BILLIARD_OPTIONS, "scan": BILLIARD_OPTIONS[1:],
                     "lyapunov": (*(o for o in BILLIARD_OPTIONS if o != "eta"), "g"),
                     "correlations": BILLIARD_OPTIONS}  # fmt: skip
#: Commands of the flat ball, and their model options.
FLAT_COMMANDS = {"tongues": ("A", "alpha", "g"), "doublings": ("alpha",)}
TINY = ["--f", "85.2", "--n", "4", "--t", "1", "--seed", "3", "--threads", "1"]
PARAMS_DEFAULTS = {f.name: f.default for f in dataclasses.fields(Params) if f.name != "f"}


def subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def model_actions(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """The actions of ``parser`` whose option is a model parameter (``--f``, ``--A``, ...)."""
    names = {f"--{name}" for name in MODEL_MEANINGS}
    return {a.dest: a for a in parser._actions if set(a.option_strings) & names}


@pytest.mark.parametrize("command", [*BILLIARD_COMMANDS, *FLAT_COMMANDS])
def test_model_options_are_the_same_everywhere(command):
    """Each command has exactly its model options, with the Params default and one help."""
    parser = subparsers()[command]
    expected = {**BILLIARD_COMMANDS, **FLAT_COMMANDS}[command]
    actions = model_actions(parser)
    assert sorted(actions) == sorted(expected)
    reference = model_actions(subparsers()["simulate"]) | model_actions(subparsers()["lyapunov"])
    for name, action in actions.items():
        if name != "f":
            assert action.default == PARAMS_DEFAULTS[name], (command, name)
            assert f"(default: {PARAMS_DEFAULTS[name]:g})" in action.help
        assert action.help.startswith(MODEL_MEANINGS[name])
        assert action.help == reference[name].help or name == "f", (command, name)
        assert action.type is reference[name].type


def _json(capsys, argv) -> dict:
    assert cli.main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def outputs():
    """simulate, gk and classify at the same tiny setting, with non-default alpha and R."""
    capture = pytest.MonkeyPatch()
    runs = {}
    for command in ("simulate", "gk", "classify"):
        buffer = io.StringIO()
        capture.setattr(sys, "stdout", buffer)
        assert cli.main([command, *TINY, "--alpha", "0.7", "--R", "30", "--json"]) == 0
        runs[command] = json.loads(buffer.getvalue())
    capture.undo()
    return runs


def test_options_reach_the_run_and_params_agree(outputs):
    expected = Params(f=85.2, alpha=0.7, R=30.0)
    for command, out in outputs.items():
        assert out["params"] == expected.to_dict(), command
        assert out["gamma"] == expected.gamma, command


def test_same_quantity_same_key_and_unit(outputs):
    sim, gk, cls = outputs["simulate"], outputs["gk"], outputs["classify"]
    # the Einstein D with its standard error over particles: D and D_se everywhere
    for out in (sim, gk, *cls["attractors"]):
        assert {"D", "D_se"} <= set(out)
    assert "D_err" not in sim and "D_err" not in gk
    # gk and simulate run the same ensemble (same seed, same estimator): the same numbers
    assert (gk["D"], gk["D_se"]) == (sim["D"], sim["D_se"])
    assert gk["E"] == sim["E"]
    # a key in several outputs has one unit
    units = [out["units"] for out in outputs.values()]
    for key in set().union(*units):
        assert len({u[key] for u in units if key in u}) == 1, key
    for key in ("D", "E", "E_x", "f", "t", "transient", "wall_s"):
        assert all(u[key] == units[0][key] for u in units), key
    assert sim["units"]["D"] == "mm^2/s" and sim["units"]["E"] == "kg mm^2/s^2"


def test_the_cli_run_is_the_api_run(outputs):
    """Non-default alpha and R reach the simulation: the API at those parameters gives the
    same D (so the options are not only echoed into ``params``)."""
    from bbdyn.ensemble import ensemble

    res = ensemble(Params(f=85.2, alpha=0.7, R=30.0), n=4, t=1.0, seed=3, threads=1,
                   observables=("displacement", "energy"))  # fmt: skip
    assert res.summary()["D"] == outputs["simulate"]["D"]
    default = ensemble(Params(f=85.2), n=4, t=1.0, seed=3, threads=1,
                       observables=("displacement", "energy"))  # fmt: skip
    assert default.summary()["D"] != outputs["simulate"]["D"]


def test_scan_json_uses_the_same_keys(tmp_path, capsys):
    argv = ["scan", "--f-start", "85", "--f-stop", "85", "--f-step", "1", "--n", "4",
            "--t", "1", "--workers", "1", "--alpha", "0.7",
            "--out", str(tmp_path / "s")]  # fmt: skip
    out = _json(capsys, argv)
    point = out["points"][0]
    assert {"D", "D_se", "E", "E_se", "E_x", "E_x_se"} <= set(point)
    assert not {"D_err", "E_err", "E_x_err"} & set(point)
    assert out["params"]["alpha"] == 0.7 and out["units"]["D"] == "mm^2/s"
    assert point["gamma"] == Params(f=85.0, alpha=0.7).gamma
    # the cost of each point: its events and time, which sum to the scan's
    assert point["events"] > 0 and 0 < point["cpu_s"] == out["cpu_s"]


def test_scan_json_points_carry_their_own_cost(tmp_path, capsys):
    argv = ["scan", "--f-start", "84", "--f-stop", "86", "--f-step", "2", "--n", "4",
            "--t", "1", "--workers", "1", "--out", str(tmp_path / "s")]  # fmt: skip
    out = _json(capsys, argv)
    points = out["points"]
    assert len(points) == 2 and math.isclose(sum(p["cpu_s"] for p in points), out["cpu_s"])
    # the point's events are those of the ensemble the point ran (seed of the point)
    from bbdyn.scans.frequency import diffusion_point
    from bbdyn.scans.runner import point_seed

    again = diffusion_point(86.0, point_seed(0, 86.0), n=4, t=1.0)
    assert points[1]["events"] == again["events"]


def test_classify_positional_frequency_is_a_deprecated_alias(capsys):
    new = _json(capsys, ["classify", *TINY])
    assert cli.main(["classify", "85.2", *TINY[2:], "--json"]) == 0
    captured = capsys.readouterr()
    old = json.loads(captured.out)
    assert "deprecated" in captured.err
    for key in ("params", "regime", "n_attractors", "unsettled_fraction"):
        assert old[key] == new[key]
    with pytest.raises(SystemExit) as both:
        cli.main(["classify", "85", *TINY])
    assert both.value.code == cli.EXIT_USAGE and "once" in capsys.readouterr().err


# ---- progress ---------------------------------------------------------------------------------
class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("command", ["simulate", "gk", "classify"])
@pytest.mark.parametrize("terminal, json_mode", [(True, False), (True, True), (False, False)])
def test_progress_only_on_a_terminal_without_json(command, terminal, json_mode, monkeypatch):
    err = FakeTerminal() if terminal else io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(sys, "stdout", io.StringIO())
    argv = [command, *TINY, "--t", "2"] + (["--json"] if json_mode else [])
    assert cli.main(argv) == 0
    text = err.getvalue()
    if terminal and not json_mode:
        assert text.startswith(f"\r{command}: 0%") and f"{command}: 100%" in text
        assert text.endswith("\n") and "left" in text
    else:
        assert text == ""


def test_progress_line_states_fraction_rate_and_time_left():
    from bbdyn.commands import RunProgress

    out = FakeTerminal()
    bar = RunProgress("simulate", 200.0, out)
    bar._t0 -= 10.0  # ten seconds ago
    bar.update_fraction(0.25)  # 50 simulated s in 10 s: 5 s/s, 30 s left
    assert bar.line() == "simulate: 25% | 5 s simulated per s | 30 s left"


# ---- python -m bbdyn ------------------------------------------------------------------------
def _run(*argv) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bbdyn", *argv], capture_output=True, text=True,
                          timeout=120, check=False)  # fmt: skip


def test_python_m_bbdyn_is_the_cli():
    assert _run("--version").stdout.strip() == f"bbdyn {__version__}"
    bad = _run("simulate", "--f", "nan")
    assert bad.returncode == cli.EXIT_USAGE and "--f" in bad.stderr
    assert "Traceback" not in bad.stderr
    out = json.loads(_run("tongues", "--kmax", "2", "--closed-form", "--json").stdout)
    assert [r["k"] for r in out["tongues"]] == [1, 2]
