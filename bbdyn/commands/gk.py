"""`bbdyn gk --f F [--A --alpha --beta --R --d --phi --eta] [--nmax 10 --n N --t T --seed S]
[--json]`.

Runs the reference ensemble at one frequency (``bbdyn.scans.green_kubo.gk_run``) and prints
the escape time tau, ``D_rw``, the measured ``r = E_y / E_x`` and ``D_a`` with it,
the truncated Green-Kubo ``D_n`` (n = 0..nmax) with bootstrap errors, the Einstein
D with its standard error, and ``p_f``, ``p_b`` (docs/model.md, section 4).  When no
particle changes trap after the transient the run is reported as trapped (regime
(a)): D_n = 0, tau infinite.  In the JSON output undefined numbers (NaN, and
tau = r = inf when nothing jumped or moved sideways) are ``null``.  Progress is shown
on stderr when it is a terminal (not with --json).

JSON keys (docs/schema.md): ``version``, ``params`` (f Hz, A mm, g mm/s^2, alpha, beta,
R mm, d mm), ``seed``, ``gamma``, ``n``, ``t``, ``transient`` (s), ``nmax``; ``D``,
``D_se`` (Einstein, standard error over particles; mm^2/s, the keys of ``bbdyn
simulate``); ``tau``, ``tau_se`` (s); ``D_rw``, ``D_a``, ``D_n`` with bootstrap standard
errors ``_se`` (mm^2/s); ``r``, ``r_se``; ``p_f``, ``p_b`` (``_se``); ``fraction_long``;
``jump_rate`` (per particle, 1/s); ``E``, ``E_x``, ``E_y`` (kg mm^2/s^2); ``D_a_reason``,
``n_jumps``, ``trapped`` (true or false) and ``trapped_reason``; ``cpu_s``, ``wall_s``
(s); ``units``.
"""

from bbdyn.commands import (
    Clock,
    add_ensemble_arguments,
    add_model_arguments,
    add_save_argument,
    integer_in,
    json_output,
    params_from,
    print_json,
    run_progress,
    save_result,
)
from bbdyn.scans.green_kubo import gk_numbers, gk_run

HELP = "random-walk and truncated Green-Kubo approximations of D at one frequency"

#: Highest accepted ``--nmax``.  D_n at order n averages products of jumps n apart, so
#: the cost grows as nmax times the number of jumps; the default is 10.
NMAX_MAX = 1000
nmax_type = integer_in(
    "nmax", 1, NMAX_MAX, "the cost grows as nmax x the number of jumps; D_n needs pairs of "
    "jumps nmax apart in one particle's sequence"
)  # fmt: skip


def add_arguments(parser) -> None:
    add_model_arguments(parser)
    parser.add_argument(
        "--nmax", type=nmax_type, default=10, help="highest order n of D_n (default: %(default)s)"
    )
    add_ensemble_arguments(parser, t=200.0)
    add_save_argument(parser)


def trapped_reason(n_jumps: int, gamma: float) -> str:
    """Why the run counts as trapped (regime (a)), or "" when some particle jumped."""
    if n_jumps:
        return ""
    reason = "regime (a), trapped: no particle changed trap after the transient"
    if gamma <= 1:
        reason += f"; Gamma = {gamma:.4g} <= 1: a particle that lands never leaves the floor"
    return reason


def gk_summary(args) -> dict:
    """Run ``gk_run`` as described by ``args``; the printed quantities as a JSON-ready dict."""
    clock = Clock()
    params = params_from(args)
    bar = run_progress("gk", args.t, args.json)
    gk = gk_run(
        params, n=args.n, t=args.t, nmax=args.nmax, seed=args.seed, threads=args.threads,
        progress=bar.update_fraction,
    )  # fmt: skip
    bar.close()
    if args.save:
        save_result(gk, args.save, args.json)
    numbers = gk_numbers(gk)
    out = {"gamma": params.gamma, "n": args.n, "t": args.t, "transient": gk.meta["transient"]}
    out["nmax"] = args.nmax
    for key, value in numbers.items():
        out[key] = value.tolist() if hasattr(value, "tolist") else value
    out["D_a_reason"] = gk.meta["D_a_reason"]
    out["n_jumps"] = gk.meta["n_jumps"]
    out["trapped_reason"] = trapped_reason(out["n_jumps"], params.gamma)
    out["trapped"] = bool(out["trapped_reason"])
    return json_output(out, params=params.to_dict(), clock=clock, seed=args.seed)


def run(args) -> int:
    import math

    out = gk_summary(args)
    if args.json:
        print_json(out)
        return 0

    def fmt(value, err=None, spec=".4g"):
        if math.isnan(value):
            return "undefined"
        return f"{value:{spec}}" + ("" if err is None or math.isnan(err) else f" +- {err:.2g}")

    p = out["params"]
    print(f"bbdyn {out['version']}  f = {p['f']} Hz  n = {out['n']}  t = {out['t']} s  "
          f"seed = {out['seed']}  (jumps after {out['transient']:g} s)")  # fmt: skip
    if out["trapped"]:
        print(f"  {out['trapped_reason']}")
    print(f"  tau            = {fmt(out['tau'], out['tau_se'])} s  ({out['n_jumps']} jumps, "
          f"{fmt(out['fraction_long'], spec='.2%')} longer than d)")  # fmt: skip
    print(f"  D_rw           = {fmt(out['D_rw'], out['D_rw_se'])} mm^2/s")
    print(f"  r = E_y / E_x  = {fmt(out['r'], out['r_se'])}")
    d_a = fmt(out["D_a"], out["D_a_se"]) + " mm^2/s"
    print(f"  D_a            = {out['D_a_reason'] if math.isnan(out['D_a']) else d_a}")
    p_f, p_b = fmt(out["p_f"], out["p_f_se"]), fmt(out["p_b"], out["p_b_se"])
    print(f"  p_f, p_b       = {p_f}, {p_b}")
    print(f"  Einstein D     = {fmt(out['D'], out['D_se'])} mm^2/s")
    print("  n   D_n (mm^2/s)")
    for k, (d_n, err) in enumerate(zip(out["D_n"], out["D_n_se"], strict=True)):
        print(f"  {k:<3} {fmt(d_n, err)}")
    print(f"  time           = {out['cpu_s']:.2f} s CPU, {out['wall_s']:.2f} s wall")
    return 0
