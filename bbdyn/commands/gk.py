"""`bbdyn gk --f F [--nmax 10 --n N --t T --seed S] [--json]`: random walk and Green-Kubo.

Runs the reference ensemble at one frequency (``bbdyn.gk_scan.gk_run``) and prints
the escape time tau, ``D_rw``, the measured ``r = E_y / E_x`` and ``D_a`` with it,
the truncated Green-Kubo ``D_n`` (n = 0..nmax) with bootstrap errors, the Einstein
D with its standard error, and ``p_f``, ``p_b`` (MODEL.md section 4).  In the JSON
output undefined numbers (NaN, and tau = inf when nothing jumped) are ``null``.
"""

HELP = "random-walk and truncated Green-Kubo approximations of D at one frequency"


def add_arguments(parser) -> None:
    parser.add_argument("--f", type=float, required=True, help="driving frequency (Hz)")
    parser.add_argument("--nmax", type=int, default=10, help="highest order n of D_n (default 10)")
    parser.add_argument("--n", type=int, default=1000, help="particles (default: 1000)")
    parser.add_argument("--t", type=float, default=200.0, help="simulated time in s (default: 200)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--save", default=None, help="also save the result to SAVE.npz/.json")


def _finite_or_none(value):
    import math

    if isinstance(value, list):
        return [_finite_or_none(v) for v in value]
    return value if math.isfinite(value) else None


def gk_summary(args) -> dict:
    """Run ``gk_run`` as described by ``args``; the printed quantities as a JSON-ready dict."""
    from bbdyn import Params, __version__
    from bbdyn.gk_scan import gk_numbers, gk_run

    params = Params(f=args.f)
    gk = gk_run(params, n=args.n, t=args.t, nmax=args.nmax, seed=args.seed, threads=args.threads)
    if args.save:
        gk.save(args.save)
    numbers = gk_numbers(gk)
    out = {"version": __version__, "params": params.to_dict(), "seed": args.seed}
    out.update(n=args.n, t=args.t, transient=gk.meta["transient"], nmax=args.nmax)
    for key, value in numbers.items():
        out[key] = _finite_or_none(value.tolist() if hasattr(value, "tolist") else value)
    out["D_a_reason"] = gk.meta["D_a_reason"]
    out["n_jumps"] = gk.meta["n_jumps"]
    out["wall_s"] = gk.meta["sim_wall_s"] + gk.meta["gk_wall_s"]
    return out


def run(args) -> int:
    import json

    out = gk_summary(args)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0

    def fmt(value, err=None, spec=".4g"):
        if value is None:
            return "undefined"
        return f"{value:{spec}}" + ("" if err is None else f" +- {err:.2g}")

    p = out["params"]
    print(f"bbdyn {out['version']}  f = {p['f']} Hz  n = {out['n']}  t = {out['t']} s  "
          f"seed = {out['seed']}  (jumps after {out['transient']:g} s)")  # fmt: skip
    print(f"  tau            = {fmt(out['tau'], out['tau_err'])} s  ({out['n_jumps']} jumps, "
          f"{fmt(out['fraction_long'], spec='.2%')} longer than d)")  # fmt: skip
    print(f"  D_rw           = {fmt(out['D_rw'], out['D_rw_err'])} mm^2/s")
    print(f"  r = E_y / E_x  = {fmt(out['r'], out['r_err'])}")
    d_a = fmt(out["D_a"], out["D_a_err"]) + " mm^2/s"
    print(f"  D_a            = {d_a if out['D_a'] is not None else out['D_a_reason']}")
    p_f, p_b = fmt(out["p_f"], out["p_f_err"]), fmt(out["p_b"], out["p_b_err"])
    print(f"  p_f, p_b       = {p_f}, {p_b}")
    print(f"  Einstein D     = {fmt(out['D'], out['D_err'])} mm^2/s")
    print("  n   D_n (mm^2/s)")
    for k, (d_n, err) in enumerate(zip(out["D_n"], out["D_n_err"], strict=True)):
        print(f"  {k:<3} {fmt(d_n, err)}")
    print(f"  wall time      = {out['wall_s']:.2f} s")
    return 0
