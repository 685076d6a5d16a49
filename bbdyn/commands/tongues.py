"""`bbdyn tongues [--A 0.1 --alpha 0.5 --g 9800] [--kmax 3] [--closed-form] [--json]`: k/1 tongues.

The model options are those of every flat-ball command (``add_model_arguments``).
JSON (docs/schema.md): ``version``, ``params`` (A mm, alpha, g mm/s^2), ``cpu_s``,
``wall_s``, ``units`` and ``tongues``, one object per k, with ``k``, ``gamma_lo``,
``gamma_hi`` (Gamma = A w^2 / g, dimensionless; closed form), ``gamma_lo_numeric``,
``gamma_hi_numeric`` (from the exact map's multipliers; null with --closed-form or at
alpha = 0), ``f_lo``, ``f_hi`` (Hz).
"""

from bbdyn.commands import (
    Clock,
    add_model_arguments,
    duration,
    integer_in,
    json_output,
    model_values,
    print_json,
)
from bbdyn.flat.tongues import OrbitNotFound, tongue_table

HELP = "k/1 Arnold tongue edges of the flat ball: closed form and from the exact map's multipliers"

#: Highest accepted ``--kmax``: the numeric edges of each k cost two root searches along
#: the exact map, ``SECONDS_PER_K`` (measured on one core for k <= 200, alpha 0.1 to 0.9).
KMAX_MAX = 1000
SECONDS_PER_K = 0.004
kmax_type = integer_in(
    "kmax", 1, KMAX_MAX,
    lambda k: f"the numeric edges cost ~{SECONDS_PER_K * 1e3:g} ms per k: about "
    f"{duration(k * SECONDS_PER_K)} for {k}" if k > KMAX_MAX else "",
)  # fmt: skip


def add_arguments(parser) -> None:
    add_model_arguments(parser, ("A", "alpha", "g"))  # the flat ball's, without f
    parser.add_argument(
        "--kmax", type=kmax_type, default=3, help="largest k (default: %(default)s)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--closed-form",
        action="store_true",
        help="closed-form edges only, no numeric check from the exact map (always at alpha = 0)",
    )


def run(args) -> int:
    clock = Clock()
    numeric = args.alpha > 0 and not args.closed_form  # at alpha = 0 the k/1 orbit sticks
    try:
        table = tongue_table(args.alpha, args.kmax, args.A, args.g, numeric=numeric)
    except OrbitNotFound as err:
        raise ValueError(
            f"the numeric tongue edges failed at alpha = {args.alpha:g}: {err}; "
            "add --closed-form for the closed-form edges only"
        ) from err
    rows = table.rows()
    if args.json:
        body = {"kmax": args.kmax, "tongues": rows}
        print_json(json_output(body, params=model_values(args), clock=clock))
        return 0
    print(f"k/1 tongues, alpha = {args.alpha}, A = {args.A} mm, g = {args.g} mm/s^2")
    print(
        f"{'k':>3} {'Gamma_lo':>12} {'Gamma_hi':>12} {'f_lo (Hz)':>10} {'f_hi (Hz)':>10}"
        f" {'rel.dev lo':>11} {'rel.dev hi':>11}"
    )
    for r in rows:
        dev = [
            "n/a" if num is None else f"{num / ref - 1:.1e}" if ref else f"{num:.1e}"
            for num, ref in (
                (r["gamma_lo_numeric"], r["gamma_lo"]),
                (r["gamma_hi_numeric"], r["gamma_hi"]),
            )
        ]
        print(
            f"{r['k']:>3} {r['gamma_lo']:>12.9f} {r['gamma_hi']:>12.9f} {r['f_lo_hz']:>10.3f}"
            f" {r['f_hi_hz']:>10.3f} {dev[0]:>11} {dev[1]:>11}"
        )
    print("rel.dev: numeric edge (multiplier +1 / -1 of the exact map) / closed form - 1")
    return 0
