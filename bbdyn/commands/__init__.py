"""Subcommands of the ``bbdyn`` CLI, one module each (entry point ``bbdyn.commands.cli``),
and what they share.

Argument types refuse a bad value while the command line is parsed, so the message
names the option (``argument --n: n must be an integer >= 2 ...``) and nothing has
run yet; output paths are checked the same way (an existing, writable folder; no
folder is created) and every saved file is reported.  ``PARAM_DEFAULTS`` are the
defaults of ``bbdyn.Params``, shown by ``--help``.

Every command takes the model parameters the same way (``add_model_arguments``,
``params_from``), prints one JSON object with the same key and unit for the same
quantity (``json_output``, the vocabulary of ``bbdyn.schema``) and shows the progress of
a long single run on a terminal (``run_progress``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

from bbdyn.params import Params
from bbdyn.results import result_paths
from bbdyn.runs import N_MIN
from bbdyn.scans.progress import Progress, progress_stream
from bbdyn.scans.progress import rough_duration as duration
from bbdyn.schema import document

#: Defaults of the fields of ``bbdyn.Params`` (f has none).
PARAM_DEFAULTS = {
    f.name: f.default for f in dataclasses.fields(Params) if f.default is not dataclasses.MISSING
}


def integer(text: str) -> int:
    """An integer option (``"12"``; not ``"1.5"`` or ``"1e3"``)."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def integer_in(name: str, low: int, high: int | None = None, why="") -> Callable[[str], int]:
    """Argument type: an integer in ``[low, high]`` (no upper bound if None).

    ``why`` explains the bound in the message: a string, or a function of the refused
    value (to state, e.g., the time it would take)."""

    def parse(text: str) -> int:
        value = integer(text)
        if value < low or (high is not None and value > high):
            bound = f">= {low}" if high is None else f"in [{low}, {high}]"
            reason = why(value) if callable(why) else why
            raise argparse.ArgumentTypeError(
                f"{name} must be an integer {bound}, got {value}"
                + (f" ({reason})" if reason else "")
            )
        return value

    return parse


def particles(text: str) -> int:
    """``--n``, the number of particles: the ensemble API's rule (``bbdyn.runs.N_MIN``),
    the same for every command."""
    why = "D, the energies and the stuck fraction carry standard errors over particles"
    return integer_in("n", N_MIN, None, why)(text)


#: ``--seed``: the seed of ``np.random.SeedSequence``, which takes integers >= 0.
seed = integer_in("seed", 0, None, "a seed of numpy's SeedSequence is a non-negative integer")
#: ``--threads``: numba threads (the upper bound, the number of cores, is checked at the run).
threads = integer_in("threads", 1)


def finite(text: str) -> float:
    """A finite real number (``"nan"``, ``"inf"`` and ``"1e999"`` are refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def _writable_folder(text: str) -> Path:
    """The path ``text`` after checking that its folder exists and is writable."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a file, got an empty path")
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(
            f"{text} is a folder; give a file name inside it, e.g. {path / 'run'}"
        )
    folder = path.parent
    if folder.exists() and not folder.is_dir():
        raise argparse.ArgumentTypeError(
            f"{folder} is a file, not a folder; choose a path in an existing folder"
        )
    if not folder.is_dir():
        raise argparse.ArgumentTypeError(
            f"folder {folder} does not exist; create it first or choose an existing folder"
        )
    if not _can_create_files_in(folder):
        raise argparse.ArgumentTypeError(f"folder {folder} is not writable; choose another folder")
    return path


def _can_create_files_in(folder: Path) -> bool:
    """Whether a file can be created in ``folder``, found by creating (and removing) one:
    permission bits alone do not tell (root may write anywhere by them, but not in /proc;
    a read-only file system)."""
    import tempfile

    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def output_folder(text: str) -> str:
    """``--out DIR`` of the commands that write a folder of results (created if missing):
    any path but an empty one (which would mean the current folder for some and the
    default for others)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a folder, got an empty path")
    return text


#: ``--save NAME``: a result saved as NAME.npz and NAME.json in an existing folder.
save_name = _writable_folder
#: ``--plot PNG``, ``--out PNG``, ``--progress FILE``: a file in an existing folder.
output_file = _writable_folder


def save_result(result, name: Path, json_mode: bool) -> None:
    """Save ``result`` (``Result.save``) as ``name`` and say where: on stdout, or on stderr
    when stdout carries JSON.  An OSError is raised again naming the files."""
    npz, json_path = result_paths(name)
    try:
        result.save(name)
    except OSError as err:
        raise OSError(err.errno, err.strerror, f"{npz}, {json_path}") from err
    report_written(f"saved {npz} and {json_path}", json_mode)


def report_written(message: str, json_mode: bool) -> None:
    """Print where output went: stdout, or stderr in ``--json`` mode (stdout is the JSON)."""
    print(message, file=sys.stderr if json_mode else sys.stdout)


def jsonable(value):
    """``value`` with numpy scalars as Python numbers and every non-finite float (NaN, inf)
    replaced by None, through dicts and lists, so that the printed JSON is strict (no NaN
    or Infinity tokens)."""
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if hasattr(value, "item") and hasattr(value, "dtype"):  # a numpy scalar
        value = value.item()
    return None if isinstance(value, float) and not math.isfinite(value) else value


def add_ensemble_arguments(parser, *, t: float, n_meaning: str = "particles") -> None:
    """The options of every ensemble run: ``--n``, ``--t`` (default ``t`` s), ``--seed``,
    ``--threads`` and ``--json``."""
    parser.add_argument("--n", type=particles, default=1000, help=f"{n_meaning} (default: 1000)")
    parser.add_argument("--t", type=finite, default=t, help=f"simulated time in s (default: {t:g})")
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--threads", type=threads, default=None, help="numba threads (default: all)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def add_save_argument(parser) -> None:
    """``--save NAME`` (a result as NAME.npz and NAME.json in an existing folder)."""
    parser.add_argument(
        "--save",
        type=save_name,
        default=None,
        metavar="NAME",
        help="also save the result as NAME.npz and NAME.json in an existing folder "
        "(default: not saved)",
    )


def param_help(name: str, meaning: str) -> str:
    """Help text of a model parameter option with its ``Params`` default."""
    return f"{meaning} (default: {PARAM_DEFAULTS[name]:g})"


# ---- model parameters: one way for every command -------------------------------------------
#: Meaning and unit of each model parameter option (``--f``, ``--A``, ...), as in ``Params``.
MODEL_MEANINGS = {
    "f": "driving frequency in Hz",
    "A": "floor amplitude in mm",
    "alpha": "normal restitution, in [0, 1]",
    "beta": "tangential restitution, in [0, 1]",
    "R": "scatterer radius in mm, > d/2 (1e9 is nearly flat)",
    "d": "scatterer width in mm",
    "g": "gravity in mm/s^2",
    "phi": "tilt of the floor in degrees, in [-15, 15]; +x is downhill for phi > 0",
    "eta": "noise amplitude of alpha and beta, drawn per collision, in [0, 1]",
}
#: The model options of a command that runs the billiard (``eta``: random restitution, for
#: the commands that run ensembles; the deterministic ones leave it out).
BILLIARD_OPTIONS = ("f", "A", "alpha", "beta", "R", "d", "phi", "eta")


def add_model_arguments(parser, names=BILLIARD_OPTIONS, *, f_required: bool = True) -> None:
    """Add the model parameter options ``names`` (``--f`` required unless ``f_required`` is
    False, the others with their ``Params`` default shown by ``--help``) in one group."""
    group = parser.add_argument_group("model parameters (docs/model.md)")
    for name in names:
        if name == "f":
            meaning = MODEL_MEANINGS["f"] + ("" if f_required else " (no default: required)")
            group.add_argument("--f", type=finite, required=f_required, help=meaning)
        else:
            group.add_argument(
                f"--{name}", type=finite, default=PARAM_DEFAULTS[name],
                help=param_help(name, MODEL_MEANINGS[name]),
            )  # fmt: skip


def model_values(args) -> dict:
    """The model parameters set by ``add_model_arguments`` in ``args``, as ``{name: value}``."""
    return {name: getattr(args, name) for name in MODEL_MEANINGS if hasattr(args, name)}


def params_from(args) -> Params:
    """``Params`` from the model options of ``args`` (a bad value: ValueError naming it)."""
    return Params(**model_values(args))


# ---- the JSON output: one object, the same key and unit for the same quantity -------------
class Clock:
    """CPU time of this process (``time.process_time``: every thread, numba's included) and
    wall-clock time since the clock was made."""

    def __init__(self):
        self.cpu0, self.wall0 = time.process_time(), time.perf_counter()

    def cpu_s(self) -> float:
        """CPU seconds of this process since the clock was made."""
        return time.process_time() - self.cpu0

    def wall_s(self) -> float:
        """Wall-clock seconds since the clock was made."""
        return time.perf_counter() - self.wall0


def json_output(body: dict, *, params: dict, clock: Clock, seed: int | None = None) -> dict:
    """The JSON object of a command (``bbdyn.schema.document``) timed by ``clock``: the
    CPU time of this process, which did the work."""
    return document(body, params=params, cpu_s=clock.cpu_s(), wall_s=clock.wall_s(), seed=seed)


def print_json(out: dict) -> None:
    """Print a command's JSON object, strict JSON (NaN and inf as null)."""
    import json

    print(json.dumps(jsonable(out), indent=2))


# ---- progress of a single run ----------------------------------------------------------------
class RunProgress(Progress):
    """One progress line for one run: per cent of the simulated time done, simulated
    seconds per wall-clock second and the time left (``update_fraction`` takes the
    fraction in [0, 1], as the ``progress=`` callback of ``bbdyn.ensemble.ensemble``)."""

    STEPS = 1000

    def __init__(self, label: str, t: float, stream):
        self.t = float(t)
        super().__init__(self.STEPS, label=label, stream=stream)

    def update_fraction(self, fraction: float) -> None:
        """Redraw at ``fraction`` (in [0, 1]) of the simulated time."""
        self.update(round(min(max(fraction, 0.0), 1.0) * self.STEPS) - self.done)

    def line(self) -> str:
        """E.g. ``simulate: 42% | 3.1 s simulated per s | 1.1 min left``."""
        fraction = self.done / self.total
        text = f"{self.label}: {100 * fraction:.0f}%"
        elapsed = time.monotonic() - self._t0
        if fraction > 0 and elapsed > 0:
            left = duration(elapsed * (1 - fraction) / fraction)
            text += f" | {fraction * self.t / elapsed:.3g} s simulated per s | {left} left"
        else:
            text += " | - s simulated per s | - left"
        return text


def run_progress(label: str, t: float, json_mode: bool) -> RunProgress:
    """The progress line of a run of ``t`` simulated seconds: on stderr when stderr is a
    terminal, silent with ``--json`` or when stderr is not a terminal."""
    return RunProgress(label, t, None if json_mode else progress_stream(True))


def add_device_argument(parser, what: str = "the particles") -> None:
    """``--device {cpu,cuda}`` (``args.device``, default cpu): where ``what`` run."""
    parser.add_argument(
        "--device", choices=("cpu", "cuda"), default="cpu",
        help=f"run {what} on the CPU (default) or on an NVIDIA GPU (cuda: pip install "
        "'bbdyn[gpu]'; docs/gpu.md)",
    )  # fmt: skip


def add_setting_arguments(parser):
    """``--quick`` (the default), ``--medium`` and ``--full``, storing ``args.setting``;
    returns their mutually exclusive group (for further modes)."""
    mode = parser.add_mutually_exclusive_group()
    for name, what in (("quick", "quick setting (default)"),
                       ("medium", "medium setting (scenes that have one)"),
                       ("full", "full (reference paper) setting")):  # fmt: skip
        mode.add_argument(f"--{name}", dest="setting", action="store_const", const=name, help=what)
    parser.set_defaults(setting="quick")
    return mode
