"""One result schema (bbdyn.schema, docs/schema.md): every command's ``--json`` is one
object with ``version``, ``params``, ``seed`` (random runs), ``cpu_s``, ``wall_s`` and
``units``, every key a quantity of the vocabulary, with its unit."""

import argparse
import json
from pathlib import Path

import pytest

from bbdyn import schema
from bbdyn.commands import cli

TINY = ["--f", "85.2", "--n", "4", "--t", "1", "--seed", "3"]


def runs(folder: Path) -> dict[str, tuple[list[str], bool]]:
    """Each command with ``--json`` at a tiny size: its arguments and whether it is random."""
    return {
        "simulate": (["simulate", *TINY, "--threads", "1"], True),
        "gk": (["gk", *TINY, "--nmax", "2", "--threads", "1"], True),
        "correlations": (["correlations", "--f", "85.2", "--n", "4", "--t", "4", "--seed", "3",
                          "--cutoff", "0.5", "--threads", "1"], True),
        "classify": (["classify", *TINY, "--threads", "1"], True),
        "lyapunov": (["lyapunov", *TINY, "--transient", "0.5"], True),
        "lyapunov --flat": (["lyapunov", "--flat", *TINY, "--transient", "0.5"], True),
        "lyapunov --spectrum": (["lyapunov", *TINY, "--transient", "0.5", "--spectrum"], True),
        "scan": (["scan", "--f-start", "85", "--f-stop", "85.2", "--f-step", "0.2", "--n", "4",
                  "--t", "1", "--seed", "3", "--workers", "1", "--out", str(folder / "scan")],
                 True),
        "tongues": (["tongues", "--kmax", "2"], False),
        "doublings": (["doublings", "--kmax", "1", "--levels", "2"], False),
        "bench": (["bench", "flat", "--quick", "--impacts", "1", "--long-run", "50",
                   "--out", str(folder / "bench.png")], False),
    }  # fmt: skip


def commands_with_json() -> set[str]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {
        name for name, sub in action.choices.items()
        if any("--json" in a.option_strings for a in sub._actions)
    }  # fmt: skip


def test_every_command_json_follows_the_schema(tmp_path, capsys):
    cases = runs(tmp_path)
    assert {argv[0] for argv, _ in cases.values()} == commands_with_json()
    outputs = {}
    for name, (argv, random) in cases.items():
        assert cli.main([*argv, "--json"]) == 0, name
        out = json.loads(capsys.readouterr().out)
        assert schema.check(out, random=random) == [], name
        if random:
            assert out["seed"] == 3, name
        outputs[name] = out
    # the same key has the same unit in every output, the vocabulary's
    for name, out in outputs.items():
        for key, unit in out["units"].items():
            assert unit == schema.QUANTITIES[key][0], (name, key)
    # the scan's CPU time is the sum of its points', each measured by its worker
    scan = outputs["scan"]
    assert scan["cpu_s"] == pytest.approx(sum(p["cpu_s"] for p in scan["points"]))
    # simulate and gk run the same ensemble: the same D and D_se under the same keys
    assert (outputs["gk"]["D"], outputs["gk"]["D_se"]) == (
        outputs["simulate"]["D"], outputs["simulate"]["D_se"])  # fmt: skip


def test_check_finds_what_breaks_the_schema():
    good = schema.document({"D": 1.0, "D_se": 0.1}, params={"f": 85.2}, cpu_s=1.0, wall_s=2.0,
                           seed=0)  # fmt: skip
    assert schema.check(good, random=True) == []
    assert schema.check([good], random=True) == ["the output must be one JSON object, got list"]
    no_seed = {k: v for k, v in good.items() if k != "seed"}
    assert schema.check(no_seed, random=True) == ["no 'seed'"]
    assert schema.check({**good, "D_err": 0.1}, random=True) == ["'D_err' is not in the schema"]
    wrong_unit = {**good, "units": {**good["units"], "D": "m^2/s"}}
    assert len(schema.check(wrong_unit, random=True)) == 1


def test_old_keys_read_as_schema_keys():
    old = {"D_err": 1.0, "collisions_per_particle_per_s": 2.0, "failures": {"a_err": 1},
           "attractors": [{"tau_err": 3.0, "jumps_per_s": 4.0}]}  # fmt: skip
    assert schema.standardise(old) == {
        "D_se": 1.0, "collision_rate": 2.0, "failures": {"a_err": 1},
        "attractors": [{"tau_se": 3.0, "jump_rate": 4.0}],
    }  # fmt: skip
    assert schema.unit("tau_se") == "s" and schema.unit("D_n_se") == "mm^2/s"
    assert all(schema.standard_key(k) in schema.QUANTITIES for k in schema.ALIASES)


def test_schema_page_is_the_vocabulary():
    """docs/schema.md shows the table ``markdown_table`` makes from the vocabulary."""
    page = Path(__file__).parents[1] / "docs" / "schema.md"
    assert schema.markdown_table() in page.read_text()
