"""`bbdyn doublings [--alpha 0.5] [--kmax 3] [--levels 8] [--json]`: period-doubling cascades.

The cascades in Gamma (dimensionless) depend on alpha only, so ``--alpha`` is the one
model option (``add_model_arguments``).  JSON (docs/schema.md): ``version``, ``params``
(alpha), ``cpu_s``, ``wall_s``, ``units`` and ``doublings``, one object per k, with
``k``, ``status``, ``reason``, ``gamma_doublings`` (Gamma of each doubling) and
``feigenbaum_ratios``.
"""

from bbdyn.commands import (
    Clock,
    add_model_arguments,
    integer_in,
    json_output,
    model_values,
    print_json,
)
from bbdyn.flat.continuation import FEIGENBAUM_DELTA, doubling_cascade

HELP = (
    "period-doubling cascades of the k/1 orbits of the flat ball: Gamma of each doubling "
    "(continuation of the exact map) and Feigenbaum ratio estimates"
)

#: Deepest cascade level accepted: level n continues an orbit of 2^(n-1) impacts, so each
#: level costs about twice the one before (12 levels: ~4 s per k on one core).
LEVELS_MAX = 14
KMAX_MAX = 20


def add_arguments(parser) -> None:
    add_model_arguments(parser, ("alpha",))  # the cascades in Gamma depend on alpha only
    parser.add_argument(
        "--kmax", type=integer_in("kmax", 1, KMAX_MAX), default=3,
        help="cascades of the k/1 orbits for k = 1..kmax (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--levels",
        type=integer_in("levels", 1, LEVELS_MAX, "each level doubles the orbit's impacts"),
        default=8,
        help="doublings per cascade (default: %(default)s)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args) -> int:
    clock = Clock()
    table = doubling_cascade(args.alpha, args.kmax, args.levels)
    rows = table.rows()
    if args.json:
        body = {"kmax": args.kmax, "levels": args.levels, "doublings": rows}
        print_json(json_output(body, params=model_values(args), clock=clock))
        return 0
    print(f"period-doubling cascades of k/1 orbits, alpha = {args.alpha} (dimensionless Gamma)")
    for r in rows:
        print(f"k = {r['k']}: {r['status']} ({r['reason']})")
        print(f"{'n':>4} {'Gamma_n':>20} {'ratio':>12}")
        ratios = [None, *r["feigenbaum_ratios"], None]
        for n, (g, q) in enumerate(zip(r["gamma_doublings"], ratios, strict=False), start=1):
            print(f"{n:>4} {g:>20.15f} {'' if q is None else f'{q:.6f}':>12}")
    print(f"ratio: (G_n - G_(n-1)) / (G_(n+1) - G_n) -> {FEIGENBAUM_DELTA:.6f} (Feigenbaum)")
    return 0
