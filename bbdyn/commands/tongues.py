"""`bbdyn tongues --alpha 0.5 --kmax 3 [--A 0.1 --g 9800] [--json]`: k/1 tongue edges."""

HELP = "k/1 Arnold tongue edges of the flat ball: closed form and from the exact map's multipliers"


def add_arguments(parser) -> None:
    parser.add_argument("--alpha", type=float, default=0.5, help="restitution (default 0.5)")
    parser.add_argument("--kmax", type=int, default=3, help="largest k (default 3)")
    parser.add_argument("--A", type=float, default=0.1, help="amplitude in mm (default 0.1)")
    parser.add_argument("--g", type=float, default=9800.0, help="gravity in mm/s^2 (default 9800)")
    parser.add_argument("--json", action="store_true", help="print a JSON list, one object per k")


def run(args) -> int:
    import json

    from bbdyn.tongues import tongue_table

    numeric = args.alpha > 0  # at alpha = 0 the k/1 orbit sticks: closed form only
    table = tongue_table(args.alpha, args.kmax, args.A, args.g, numeric=numeric)
    rows = table.rows()
    if args.json:
        print(json.dumps(rows, indent=2))
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
