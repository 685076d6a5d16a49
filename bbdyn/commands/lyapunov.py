"""`bbdyn lyapunov --f F [--A --alpha --g] [--n N --t T --seed S] [--json]`: Lyapunov exponents.

Runs ``bbdyn.lyapunov.flat_lyapunov`` (the flat ball: the billiard's tangent
dynamics is not implemented yet, docs/lyapunov.md) and prints both exponents
per second and per impact with their standard errors over the particles, the
conditional exponents (growth between sticks), the stuck fraction and the
largest exponent of each time window (convergence check).

JSON keys: ``model`` ("flat"), ``params`` (f Hz, A mm, g mm/s^2, alpha; beta, R, d
unused by the flat ball), ``f``, ``gamma``, ``n``, ``t`` (s); ``lam1_per_s``,
``lam2_per_s`` and ``cond_...`` (1/s), ``..._per_impact`` (per impact), each with ``_se``;
``stuck_fraction``; ``window_cond_lam1_per_s`` (1/s); ``wall_s`` (s); ``units``.
"""

from bbdyn.commands import (
    FLAT_OPTIONS,
    add_model_arguments,
    finite,
    integer_in,
    jsonable,
    params_from,
    seed,
    units_of,
)

HELP = "Lyapunov exponents of the flat ball (tangent dynamics through impacts and sticks)"

#: ``--n``: at least 2 particles for a standard error.
n_type = integer_in("n", 2, 100_000, "the standard errors are over particles")
windows_type = integer_in("windows", 1, 1000, "the run is split into this many windows")


def add_arguments(parser) -> None:
    add_model_arguments(parser, FLAT_OPTIONS)
    parser.add_argument("--n", type=n_type, default=20, help="particles (default: 20)")
    parser.add_argument(
        "--t", type=finite, default=20.0, help="measured time in s (default: %(default)g)"
    )
    parser.add_argument(
        "--transient", type=finite, default=2.0,
        help="time run first, not measured, in s (default: %(default)g)",
    )  # fmt: skip
    parser.add_argument(
        "--windows", type=windows_type, default=4,
        help="windows of the convergence check (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def lyapunov_summary(args) -> dict:
    """Run the flat-ball exponents for ``args``; the summary dict with the window exponents."""
    from bbdyn.lyapunov import flat_lyapunov

    params = params_from(args)
    res = flat_lyapunov(
        params, args.n, t=args.t, transient=args.transient, windows=args.windows, seed=args.seed
    )
    out = {"model": "flat", "params": params.to_dict(), "f": args.f, "gamma": params.gamma}
    out.update(n=args.n, t=args.t)
    out.update(res.summary())
    out["window_cond_lam1_per_s"] = [float(x) for x in res.window_exponents()]
    if out["stuck_fraction"] > 0:
        out["note"] = "exponents -inf (null in JSON): a particle stuck, which forgets its state"
    out["wall_s"] = res.meta["wall_s"]
    out["units"] = units_of(out)
    return out


def run(args) -> int:
    import json

    s = lyapunov_summary(args)
    if args.json:
        print(json.dumps(jsonable(s), indent=2))
        return 0
    print(
        f"flat ball, f = {s['f']:g} Hz (Gamma = {s['gamma']:.4f}), n = {s['n']}, t = {s['t']:g} s"
    )
    print(f"stuck at least once: {s['stuck_fraction']:.3f} of the particles (exponent -inf)")
    for tag, unit in (("per_s", "1/s"), ("per_impact", "per impact")):
        for pre, what in (("", "exponents"), ("cond_", "conditional (between sticks)")):
            vals = [
                f"{s[f'{pre}lam{i}_{tag}']:.5g} +- {s[f'{pre}lam{i}_{tag}_se']:.2g}" for i in (1, 2)
            ]
            print(f"{what:>30} {unit:>10}: lam1 = {vals[0]}, lam2 = {vals[1]}")
    windows = ", ".join(f"{x:.4g}" for x in s["window_cond_lam1_per_s"])
    print(f"conditional lam1 per window (1/s): {windows}")
    return 0
