"""The README's first screen: its Python example runs and prints what it says (the numbers of
``bbdyn simulate``), and its command table lists every command with options that exist."""

import argparse
import contextlib
import io
import json
import re
from pathlib import Path

import pytest

from bbdyn.commands import cli

README = Path(__file__).resolve().parents[1] / "README.md"
SETUP = (
    "    python -m pip install -e . && bbdyn reproduce --quick --out out",
    "    python -m pip install -e '.[test]' && python -m pytest",
)


def readme() -> str:
    return README.read_text(encoding="utf-8")


def python_block() -> str:
    blocks = re.findall(r"```python\n(.*?)```", readme(), flags=re.S)
    assert len(blocks) == 1, "the README has one Python example"
    return blocks[0]


def table_rows() -> list[str]:
    """The command cells of the README's command table (``bbdyn ...``)."""
    return re.findall(r"^\| `(bbdyn [^`]*)` \|", readme(), flags=re.M)


def subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def test_setup_commands_are_the_two_of_the_first_screen():
    lines = readme().splitlines()
    assert all(command in lines for command in SETUP)
    assert max(lines.index(command) for command in SETUP) < 25


def test_python_example_is_short_and_prints_what_simulate_prints(capsys):
    code = python_block()
    assert len(code.strip().splitlines()) == 5
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    line = r"D = (\S+) \+- (\S+) mm\^2/s, E = (\S+) kg mm\^2/s\^2\n"
    printed = re.fullmatch(line, out.getvalue())
    assert printed, out.getvalue()
    # the README says: the numbers `bbdyn simulate --f 85.2 --n 100 --t 20 --json` prints
    claim = re.search(r"the numbers `bbdyn (simulate [^`]*)` prints", readme()).group(1).split()
    assert cli.main([*claim, "--seed", "0"]) == 0
    sim = json.loads(capsys.readouterr().out)
    assert printed.groups() == (f"{sim['D']:.3g}", f"{sim['D_se']:.2g}", f"{sim['E']:.4g}")


def test_table_lists_every_command_with_real_options():
    parsers = subparsers()
    rows = table_rows()
    assert {row.split()[1] for row in rows} == set(cli.COMMANDS)
    for row in rows:
        name = row.split()[1]
        known = {s for a in parsers[name]._actions for s in a.option_strings}
        for option in re.findall(r"(?<![\w-])--[a-z][\w-]*", row):
            assert option in known, (name, option)


@pytest.mark.parametrize("setting", ["--quick", "--medium", "--full", "--docs"])
def test_table_shows_the_settings_of_reproduce(setting):
    assert any(row.startswith("bbdyn reproduce") and setting in row for row in table_rows())


def test_stated_defaults_are_those_of_the_parsers():
    """Every ``--name number`` in the README's MODEL/RUN paragraph is that option's default."""
    paragraph = readme().split("MODEL is the model parameters", 1)[1].split("\n\n", 1)[0]
    stated = re.findall(r"--(\w+) ([0-9.]+)", paragraph)
    assert len(stated) >= 7
    defaults = {a.dest: a.default for a in subparsers()["simulate"]._actions}
    defaults |= {a.dest: a.default for a in subparsers()["lyapunov"]._actions if a.dest == "g"}
    for name, value in stated:
        assert float(value) == defaults[name], name
