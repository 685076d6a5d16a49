"""`bbdyn classify --f F [--A --alpha --beta --R --d --phi --eta] [--n N --t T --seed S --box ...]
[--hop-floor P] [--json]`.

Runs ``bbdyn.classify.classify`` and prints the verdict and its evidence: the
regime (docs/model.md, section 5), ergodicity with its numbers, and each attractor with
its basin fraction, locking, period, stuck fraction, jump rate, its Einstein D (the
estimator of ``bbdyn simulate`` over the attractor's particles, with D in successive
windows) and its energies (kg mm^2/s^2).  Progress is shown on stderr when it is a
terminal (not with --json).  ``bbdyn classify F`` (the frequency as a positional
argument) still works but is deprecated: use ``--f F`` as every other command.

JSON keys (docs/schema.md): ``version``, ``params`` (f Hz, A mm, g mm/s^2, alpha, beta,
R mm, d mm), ``seed``, ``gamma``, ``n``, ``t``, ``transient`` (s), ``boxes``; ``regime``,
``regime_meaning``, ``reason``, ``ergodic``, ``ergodicity``; ``attractors`` (each with
``fraction``, ``D``, ``D_se`` in mm^2/s, ``D_windows``, energies ``E``, ``E_x``, ``E_y``,
``E_pot`` with ``_se`` in kg mm^2/s^2, ``jump_rate`` 1/s, ...); ``E_reference``;
``unsettled_fraction``, ``failed_fraction``, ``failures``; ``thresholds``; ``cpu_s``,
``wall_s`` (s); ``units`` (the unit of each dimensioned key, here and in the attractors).
"""

import argparse
import sys

from bbdyn import Params
from bbdyn.classify import Thresholds, classify
from bbdyn.commands import (
    Clock,
    add_ensemble_arguments,
    add_model_arguments,
    finite,
    json_output,
    output_file,
    params_from,
    print_json,
    report_written,
    run_progress,
)
from bbdyn.ensemble import Box, ensemble, reference_box

HELP = "classify the dynamics at one frequency: attractors, basins, ergodicity, regime"

#: Named boxes for ``--box`` (besides explicit numbers).
BOX_NAMES = ("ref", "high")


def add_arguments(parser) -> None:
    add_model_arguments(parser, f_required=False)  # --f or the deprecated positional F
    parser.add_argument(  # deprecated alias of --f
        "f_positional", nargs="?", type=finite, default=None, metavar="F", help=argparse.SUPPRESS
    )
    add_ensemble_arguments(parser, t=50.0, n_meaning="particles per box")
    parser.add_argument(
        "--transient", type=finite, default=None, help="discarded time (s; default: t/2)"
    )
    parser.add_argument(
        "--box",
        action="append",
        default=None,
        metavar="BOX",
        help="initial box: 'ref' (the reference box), 'high' (vy+ in (40, 400] mm/s) or "
        "'s0,s1,vx0,vx1,vy0,vy1'; repeat for several boxes (default: ref)",
    )
    parser.add_argument(
        "--hop-floor", type=finite, default=None, metavar="PERIODS",
        help="impacts after flights shorter than this are not counted as collisions "
        "(periods; default 1e-4; 0 counts every impact; docs/classification.md)",
    )  # fmt: skip
    parser.add_argument(
        "--plot", type=output_file, default=None, metavar="PNG",
        help="draw S6/S7/S8-style panels into PNG, in an existing folder (default: no plot)",
    )  # fmt: skip


def use_positional_frequency(args) -> None:
    """Accept the deprecated ``bbdyn classify F``: set ``args.f`` from it, with a note on
    stderr; refuse it together with ``--f`` or no frequency at all."""
    given = args.f_positional
    if given is None:
        if args.f is None:
            raise ValueError("the following arguments are required: --f")
        return
    if args.f is not None:
        raise ValueError(f"give the frequency once: --f {args.f:g} or the deprecated {given:g}")
    print(f"bbdyn classify: note: 'classify {given:g}' is deprecated, write "
          f"'classify --f {given:g}'", file=sys.stderr)  # fmt: skip
    args.f = given


def parse_box(text: str, params):
    """A ``Box`` from a name in ``BOX_NAMES`` or six comma-separated numbers."""
    if text == "ref":
        return reference_box(params)
    if text == "high":
        return Box(s=(0.0, params.s_max), vx=(-40.0, 40.0), vy=(40.0, 400.0))
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 6:
        raise ValueError(f"box must be one of {BOX_NAMES} or 's0,s1,vx0,vx1,vy0,vy1', got {text!r}")
    return Box(s=(v[0], v[1]), vx=(v[2], v[3]), vy=(v[4], v[5]))


def classify_summary(args):
    """Run the classifier described by ``args``; returns ``(summary dict, Classification)``."""
    clock = Clock()
    params = params_from(args)
    thresholds = Thresholds() if args.hop_floor is None else Thresholds(hop_floor=args.hop_floor)
    boxes = [parse_box(b, params) for b in (args.box or ["ref"])]
    bar = run_progress("classify", args.t, args.json)
    res = classify(
        params, t=args.t, n=args.n, seed=args.seed, boxes=boxes, transient=args.transient,
        thresholds=thresholds, threads=args.threads, progress=bar.update_fraction,
    )  # fmt: skip
    bar.close()
    out = {"boxes": [vars(b) for b in boxes]}
    out.update((k, v) for k, v in res.summary.items() if k != "units")
    return json_output(out, params=params.to_dict(), clock=clock, seed=args.seed), res


def plot_attractors(res, path) -> None:
    """Save ``attractor_figure(res)`` as the PNG ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = attractor_figure(res)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def attractor_figure(res):
    """The classification's overview (``Classification.plot``) in the left column and, per
    attractor, (s, vx+) and (y, vy+) at collisions of its representative (S6/S7/S8 style);
    without attractors only the overview.  Returns the Figure."""
    import matplotlib.pyplot as plt
    import numpy as np

    params = Params(**res.meta["params"])
    atts = res.summary["attractors"]
    # the overview spans the left column; each attractor fills a row of the two others
    rows, cols = max(len(atts), 1), 3 if atts else 1
    fig = plt.figure(figsize=(4.0 * cols, 3.2 * rows), layout="constrained")
    grid = fig.add_gridspec(rows, cols)
    res.plot(ax=fig.add_subplot(grid[:, 0]))
    t = res.summary["t"]
    for a, att in enumerate(atts):
        run = ensemble(
            params, t=t, initial=[att["representative"]["initial"]], observables=("record",),
            record_particles=1, record_window=(res.summary["transient"], t), record_capacity=20000,
        )  # fmt: skip
        rec = run["record"][0, : min(run["record_n"][0], 20000)]
        xi = rec[:, 3]
        s = params.R * (np.arcsin(xi / params.R) + np.arcsin(params.d / (2 * params.R)))
        b = np.sqrt(params.R**2 - xi**2) - np.sqrt(params.R**2 - params.d**2 / 4)
        u = -params.A * params.w * np.cos(rec[:, 1])
        y = -params.A * np.sin(rec[:, 1]) + b
        ax_s, ax_y = fig.add_subplot(grid[a, 1]), fig.add_subplot(grid[a, 2])
        ax_s.plot(s, rec[:, 4], ".", ms=1)
        ax_s.set(xlabel="s (mm)", ylabel="vx+ (mm/s)", title=f"attractor {a}: (s, vx+)")
        ax_y.plot(y, rec[:, 5] + u, ".", ms=1)
        ax_y.set(xlabel="y (mm)", ylabel="vy+ (mm/s)", title=f"{att['character']}: (y, vy+)")
    return fig


def run(args) -> int:
    use_positional_frequency(args)
    out, res = classify_summary(args)
    if args.plot:
        plot_attractors(res, args.plot)
        report_written(f"plot: {args.plot}", args.json)
    if args.json:
        print_json(out)
        return 0
    e = out["ergodicity"]
    print(f"bbdyn {out['version']}  f = {out['f']} Hz (Gamma = {out['gamma']:.4f})  n = {out['n']}"
          f"  t = {out['t']} s  seed = {out['seed']}")  # fmt: skip
    print(f"  regime {out['regime']}: {out['regime_meaning']}")
    print(f"  because {out['reason']}")
    chi2 = ", ".join(f"{k} {v:.3g}" for k, v in e["reduced_chi2"].items())
    print(f"  ergodic {out['ergodic']}: {e['n_attractors']} attractor(s), unsettled "
          f"{e['unsettled_fraction']:.3g}, reduced chi2 [{chi2}] "
          f"(<= {e['max_reduced_chi2']})")  # fmt: skip
    if out["failed_fraction"]:
        print(f"  failed {out['failed_fraction']:.3g} of the trajectories ({out['failures']}): "
              "left out of every attractor")  # fmt: skip
    for a, att in enumerate(out["attractors"]):
        print_attractor(a, att, out["units"])
    print(f"  time {out['cpu_s']:.2f} s CPU, {out['wall_s']:.2f} s wall")
    return 0


def print_attractor(a: int, att: dict, units: dict) -> None:
    """Print attractor ``a`` of a classification summary: its character, D and energies."""
    print(f"  attractor {a}: fraction {att['fraction']:.3f}, {att['character']}, "
          f"locking_k {att['locking_k']}, period {att['period']}, "
          f"stuck {att['stuck_fraction']:.3g}, tiny hops {att['tiny_fraction']:.3g}, "
          f"locked flights {att['locked_fraction']:.3g}, "
          f"jump rate {att['jump_rate']:.3g}/s")  # fmt: skip
    w = att["D_windows"]
    by_window = ", ".join(f"{d:.3g}+-{s:.2g}" for d, s in zip(w["D"], w["D_se"], strict=True))
    print(f"    D = {att['D']:.4g} +- {att['D_se']:.2g} {units['D']} "
          f"(by window from 0.2 t: {by_window})")  # fmt: skip
    energies = ", ".join(
        f"{name} {att[name]:.5g} +- {att[name + '_se']:.2g}"
        for name in ("E", "E_x", "E_y", "E_pot")
    )
    print(f"    {energies} {units['E']}")
