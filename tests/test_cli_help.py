"""``--help`` of the commands: every option states its default, and the model parameters'
defaults are those of ``bbdyn.Params`` (the values a run uses, not a pointer to a document)."""

import argparse
import dataclasses
import re

import pytest

from bbdyn import Params
from bbdyn.commands import cli

OWN = ("simulate", "gk", "tongues", "bench", "classify", "lyapunov", "scan", "doublings")
#: a minimal valid command line of each command (for the parsed defaults)
MINIMAL = {
    "simulate": ["--f", "60"],
    "gk": ["--f", "60"],
    "tongues": [],
    "bench": ["flat"],
    "classify": ["--f", "60"],
    "lyapunov": ["--f", "60"],
    "scan": ["--out", "x"],
    "doublings": [],
}
DOCUMENTS = re.compile(r"(MODEL|SCENES|STYLE)\.md")


def subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def expanded_help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    return parser._get_formatter()._expand_help(action)


@pytest.mark.parametrize("command", OWN)
def test_every_option_states_its_default(command):
    parser = subparsers()[command]
    for action in parser._actions:
        if not action.option_strings or action.nargs == 0 or action.required:  # no default
            continue
        assert "default" in expanded_help(parser, action), (command, action.option_strings)


@pytest.mark.parametrize("command", OWN)
def test_help_shows_the_parameter_defaults_a_run_uses(command, capsys):
    parser = subparsers()[command]
    args = parser.parse_args(MINIMAL[command])
    defaults = {f.name: f.default for f in dataclasses.fields(Params) if f.name != "f"}
    assert defaults == {k: v for k, v in Params(f=1.0).to_dict().items() if k != "f"}
    for action in parser._actions:
        if action.dest in defaults:
            assert getattr(args, action.dest) == defaults[action.dest]
            stated = f"(default: {defaults[action.dest]:g})"
            assert stated in expanded_help(parser, action), (command, action.dest)


@pytest.mark.parametrize("command", [None, *OWN])
def test_help_mentions_no_specification_file(command, capsys):
    argv = ["--help"] if command is None else [command, "--help"]
    with pytest.raises(SystemExit) as done:
        cli.main(argv)
    assert done.value.code == 0
    text = capsys.readouterr().out
    assert "usage: bbdyn" in text and not DOCUMENTS.search(text)
