"""`bbdyn correlations --f F [--A --alpha --beta --R --d --phi --eta] [--n N --t T --seed S]
[--cutoff T_C] [--json] [--save NAME]`.

Runs ``bbdyn.correlations.correlations`` at one frequency: the Green-Kubo integral of the
velocity autocorrelation ``D_GK`` (to the cutoff, and its mean over cutoffs in ``[T/2,
T]``) against the Einstein D of an independent ensemble, with the pull ``z``; the excess
kurtosis of the displacement at its peak and at the longest lag; the tiles crossed per
flight (docs/distributions.md).

JSON keys (docs/schema.md): ``version``, ``params``, ``seed``, ``gamma``, ``n``, ``t``,
``transient``, ``cutoff`` (s); ``D_GK``, ``D_GK_se``, ``D_GK_mean``, ``D_GK_mean_se``,
``D``, ``D_se`` (mm^2/s); ``z``, ``z_mean``; ``C0_binned`` (mm^2/s^2) and ``E_x``,
``E_x_se`` (kg mm^2/s^2); ``kurtosis_max``, ``kurtosis_max_se``, ``kurtosis_max_lag`` (s);
``flights``, ``jump_counts``; ``cpu_s``, ``wall_s``; ``units``.
"""

import numpy as np

from bbdyn.commands import (
    Clock,
    add_ensemble_arguments,
    add_model_arguments,
    add_save_argument,
    finite,
    json_output,
    params_from,
    print_json,
    save_result,
)
from bbdyn.correlations import correlations

HELP = "velocity autocorrelation, Green-Kubo D against Einstein D, distributions at one f"


def add_arguments(parser) -> None:
    add_model_arguments(parser)
    add_ensemble_arguments(parser, t=50.0)
    parser.add_argument(
        "--cutoff", type=finite, default=10.0,
        help="upper limit T of the Green-Kubo integral in s, at most a third of the window "
        "after the transient t/5 (default: %(default)s)",
    )  # fmt: skip
    add_save_argument(parser)


def summary(args) -> dict:
    """Run ``correlations`` as described by ``args``; the printed numbers as a JSON-ready dict."""
    clock = Clock()
    params = params_from(args)
    res = correlations(
        params, n=args.n, t=args.t, seed=args.seed, cutoff=args.cutoff,
        times=(min(args.cutoff, 1.0),), threads=args.threads,
    )  # fmt: skip
    if args.save:
        save_result(res, args.save, args.json)
    m = res.meta
    out = {"gamma": params.gamma, "n": m["n"], "t": m["t"], "transient": m["transient"]}
    for key in ("cutoff", "D_GK", "D_GK_se", "D_GK_mean", "D_GK_mean_se", "D", "D_se", "z",
                "z_mean", "flights"):  # fmt: skip
        out[key] = m[key]
    out["C0_binned"] = float(res["C"][0])
    out["E_x"], out["E_x_se"] = m["two_E_x"] / 2, m["two_E_x_se"] / 2
    k = int(np.nanargmax(res["kurtosis"]))
    out["kurtosis_max"] = float(res["kurtosis"][k])
    out["kurtosis_max_se"] = float(res["kurtosis_se"][k])
    out["kurtosis_max_lag"] = float(res["kurtosis_lags"][k])
    out["jump_counts"] = res["jump_counts"].tolist()
    return json_output(out, params=params.to_dict(), clock=clock, seed=args.seed)


def run(args) -> int:
    out = summary(args)
    if args.json:
        print_json(out)
        return 0
    p = out["params"]
    print(f"bbdyn {out['version']}  f = {p['f']} Hz  n = {out['n']}  t = {out['t']} s  "
          f"seed = {out['seed']}  (averages after {out['transient']:g} s)")  # fmt: skip
    print(f"  D_GK (cutoff {out['cutoff']:g} s)   = {out['D_GK']:.4g} +- {out['D_GK_se']:.2g} "
          "mm^2/s")  # fmt: skip
    print(f"  D_GK, mean over [T/2, T] = {out['D_GK_mean']:.4g} +- {out['D_GK_mean_se']:.2g} "
          "mm^2/s")  # fmt: skip
    print(f"  Einstein D               = {out['D']:.4g} +- {out['D_se']:.2g} mm^2/s")
    print(f"  z, z (mean)              = {out['z']:.2f}, {out['z_mean']:.2f}")
    print(f"  excess kurtosis, peak    = {out['kurtosis_max']:.3g} +- "
          f"{out['kurtosis_max_se']:.2g} at {out['kurtosis_max_lag']:.3g} s")  # fmt: skip
    print(f"  flights by tiles crossed = {out['jump_counts']} ({out['flights']} flights)")
    print(f"  time                     = {out['cpu_s']:.2f} s CPU, {out['wall_s']:.2f} s wall")
    return 0
