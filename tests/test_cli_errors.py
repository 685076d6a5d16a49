"""How ``bbdyn.commands.cli.main`` ends every kind of failure: exit status, a short message,
no traceback.

Each failure is provoked where it really happens (a bad path, a closed pipe) or, where
that cannot be done safely in a test (no space left, out of memory, a kernel failure,
a bug), by a command whose ``run`` raises it.
"""

import errno
import json
import subprocess
import sys

import pytest
from test_cli_bad_inputs import run_main

from bbdyn.commands import bench, cli, tongues
from bbdyn.core.status import SimulationError

SIM = ["simulate", "--f", "85.2", "--n", "4", "--t", "1"]


def short_message(err: str) -> list[str]:
    lines = err.strip().splitlines()
    assert 1 <= len(lines) <= 3, err
    assert "Traceback" not in err
    return lines


@pytest.fixture
def tongues_raises(monkeypatch):
    """Make ``bbdyn tongues`` raise the given exception."""

    def install(exc):
        def run(args):
            raise exc

        monkeypatch.setattr(tongues, "run", run)

    return install


# ---- output paths: checked before the run, reported after it -----------------------------


def test_save_into_a_missing_folder_is_refused_and_nothing_is_created(tmp_path, capsys):
    target = tmp_path / "missing" / "deeper" / "run"
    assert run_main([*SIM, "--save", str(target)]) == 2
    lines = short_message(capsys.readouterr().err)
    assert f"folder {target.parent} does not exist" in lines[0]
    assert not (tmp_path / "missing").exists()


def test_save_below_a_file_names_the_file(capsys):
    assert run_main([*SIM, "--save", "/dev/null/x"]) == 2
    assert "/dev/null is a file, not a folder" in short_message(capsys.readouterr().err)[0]


def test_save_onto_a_folder_is_refused(tmp_path, capsys):
    assert run_main([*SIM, "--save", str(tmp_path)]) == 2
    assert f"{tmp_path} is a folder" in short_message(capsys.readouterr().err)[0]


def test_an_unwritable_folder_is_refused_before_the_run(monkeypatch, capsys):
    """/proc exists and its permission bits let root write, but no file can be made there:
    refused while the command line is parsed, before the benchmark runs."""
    monkeypatch.setattr(bench, "run_scene", lambda *a, **k: pytest.fail("it ran"))
    assert run_main(["bench", "flat", "--quick", "--out", "/proc/bbdyn_b.png"]) == 2
    assert "folder /proc is not writable" in short_message(capsys.readouterr().err)[0]


@pytest.mark.parametrize("json_mode", [False, True], ids=["text", "json"])
def test_save_says_where_it_saved(tmp_path, capsys, json_mode):
    name = tmp_path / "run"
    assert run_main([*SIM, "--save", str(name)] + ["--json"] * json_mode) == 0
    out, err = capsys.readouterr()
    said = f"saved {name}.npz and {name}.json"
    assert (name.with_suffix(".npz")).exists() and (name.with_suffix(".json")).exists()
    if json_mode:  # stdout stays pure JSON
        assert said in err and json.loads(out)["n"] == 4
    else:
        assert said in out and err == ""


def test_no_space_left_names_the_files_and_says_what_to_do(tmp_path, capsys, monkeypatch):
    def full(self, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("bbdyn.results.Result.save", full)
    name = tmp_path / "run"
    assert run_main([*SIM, "--save", str(name)]) == 1
    lines = short_message(capsys.readouterr().err)
    assert f"{name}.npz" in lines[0] and "No space left on device" in lines[0]
    assert "free space" in lines[1]


def test_unwritable_path_in_an_existing_folder(capsys):
    """/proc accepts no new files, even for root: refused before the run, naming the folder
    (a write that fails later names its files: test_no_space_left_...)."""
    assert run_main([*SIM, "--save", "/proc/bbdyn_test_run"]) == 2
    assert "folder /proc is not writable" in short_message(capsys.readouterr().err)[0]


def test_classify_plot_into_a_missing_folder_is_refused_before_the_run(tmp_path, capsys):
    png = tmp_path / "no" / "x.png"
    argv = ["classify", "--f", "85.2", "--n", "4", "--t", "2", "--plot", str(png)]
    assert run_main(argv) == 2
    assert f"folder {png.parent} does not exist" in short_message(capsys.readouterr().err)[0]


# ---- the other failures ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("exc", "status", "words"),
    [
        (ValueError("kmax must be positive"), 2, ["kmax must be positive", "--help"]),
        (ValueError("first line\n  second line\n"), 2, ["first line; second line"]),
        (TypeError("f must be a real number"), 2, ["f must be a real number"]),
        (MemoryError("Unable to allocate 7.5 TiB"), 1, ["out of memory", "7.5 TiB", "reduce"]),
        (OverflowError("(34, 'Numerical result out of range')"), 2, ["too large", "smaller"]),
        (SimulationError("particle 3: non-finite value"), 1,
         ["simulation failed", "particle 3", "kmax=3", "report it"]),
        (RuntimeError("unexpected"), 1,
         ["RuntimeError: unexpected", "this is a bug", "BBDYN_DEBUG"]),
    ],
    ids=["value", "multiline", "type", "memory", "overflow", "simulation", "bug"],
)  # fmt: skip
def test_each_failure_gets_its_status_and_a_message_saying_what_to_do(
    tongues_raises, capsys, exc, status, words
):
    tongues_raises(exc)
    assert run_main(["tongues"]) == status
    err = "\n".join(short_message(capsys.readouterr().err))
    assert err.startswith("bbdyn tongues: ")
    for word in words:
        assert word in err


def test_debug_variable_shows_the_traceback(tongues_raises, monkeypatch):
    tongues_raises(RuntimeError("unexpected"))
    monkeypatch.setenv("BBDYN_DEBUG", "1")
    with pytest.raises(RuntimeError, match="unexpected"):
        cli.main(["tongues"])


def test_keyboard_interrupt_exits_130(tongues_raises, capsys):
    tongues_raises(KeyboardInterrupt())
    assert run_main(["tongues"]) == 130
    assert capsys.readouterr().err.strip() == "interrupted"


def test_usage_errors_are_two_lines_without_the_usage_block(capsys):
    assert run_main(["simulate", "--f", "abc"]) == 2
    lines = short_message(capsys.readouterr().err)
    assert lines == [
        "bbdyn simulate: error: argument --f: must be a number, got 'abc'",
        "run 'bbdyn simulate --help' for the options and their defaults",
    ]


def test_success_returns_zero_and_help_exits_zero(capsys):
    assert run_main(["tongues", "--kmax", "1"]) == 0
    assert run_main(["tongues", "--help"]) == 0


@pytest.mark.parametrize(
    ("argv", "status"),
    [(["tongues", "--kmax", "3", "--json"], 141), (["--help"], 0)],
    ids=["tongues", "help"],
)
def test_closed_pipe_exits_quietly(argv, status):
    """``bbdyn tongues --json | head -c 0``: the reader is gone before the first write; the
    command exits 141 (128 + SIGPIPE, as a tool killed by SIGPIPE) with nothing on stderr.
    argparse itself ignores a failed write of the help text, so ``--help`` exits 0."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "bbdyn.commands.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    proc.stdout.close()
    _, err = proc.communicate(timeout=120)
    assert err == "" and proc.returncode == status


def test_an_oserror_that_is_not_about_a_path_keeps_its_own_remedy():
    """The path hint is for path errors only: e.g. an unreachable scheduler says what to do."""
    from bbdyn.commands.cli import explain

    status, text = explain(OSError("no scheduler answers at tcp://x: start it"), None)
    assert status != 0 and "start it" in text and "check the path" not in text
    status, text = explain(FileNotFoundError(2, "No such file or directory", "/nope/x"), None)
    assert "/nope/x" in text and "check the path" in text
