"""`bbdyn lyapunov --f F [MODEL] [--n N --t T --seed S] [--spectrum] [--flat] [--json]`: Lyapunov
exponents.

The billiard (default): ``bbdyn.lyapunov.billiard_lyapunov`` runs ``n`` particles from
the reference box with one tangent vector each (docs/lyapunov.md) and prints the largest
exponent per second and per collision with its standard error over particles, for the
whole ensemble and, after classifying the same initial conditions with
``bbdyn.classify`` (skip with ``--no-classify``), for each attractor the classifier
finds; with the largest exponent of each time window (convergence check).
``--spectrum``: all four exponents of the billiard's section map (four tangent vectors,
QR every ``--qr-every`` impact-to-impact events), with their sum against the closed-form
``log |det J|`` and the sticks (each leaves one finite exponent).

``--flat``: the flat ball (``bbdyn.lyapunov.flat_lyapunov``; ``--A --alpha --g`` only):
both exponents per second and per impact, the conditional exponents (growth between
sticks), the stuck fraction and the window exponents.

JSON keys (docs/schema.md), both: ``version``, ``params``, ``seed``, ``model``, ``f``,
``gamma``, ``n``, ``t`` (s), ``cpu_s``, ``wall_s`` (s), ``units``.  Billiard (``model``
"billiard"): ``transient`` (s), ``per`` ("attractor" or "ensemble"); ``lam1_per_s``,
``lam1_per_s_se`` (1/s), ``lam1_per_collision``, ``lam1_per_collision_se``, the same with
``cond_`` (growth between collapses), ``collapse_fraction``, ``collision_rate`` (1/s),
``window_cond_lam1_per_s`` (1/s) for the ensemble; ``attractors``: a list of the same keys
with ``attractor``, ``fraction``, ``character``; ``regime``; with ``--spectrum`` also
``qr_every`` and the keys of ``BilliardLyapunovResult.spectrum_summary``
(``spectrum_per_s``, ``spectrum_per_collision``, ``free_spectrum_per_s``,
``free_spectrum_per_event`` with ``_se``: lists of four, largest first;
``spectrum_sum_per_event``, ``log_det_per_event``, ``spectrum_sum_deviation``,
``stuck_fraction``, ``stick_event_fraction``, ``carried_fraction``, ``inf_exponents``).
Flat (``model`` "flat"):
``lam1_per_s``, ``lam2_per_s`` and ``cond_...`` (1/s), ``..._per_impact``, each with
``_se``; ``stuck_fraction``; ``impact_rate`` (1/s); ``window_cond_lam1_per_s``.  Both, with
the window exponents (and for each attractor): ``window_chi2``, ``window_dof``, ``window_p``
and ``windows_agree`` (``bbdyn.lyapunov.window_agreement``; false: a warning on stderr).
"""

from bbdyn.commands import (
    BILLIARD_OPTIONS,
    Clock,
    add_model_arguments,
    finite,
    integer_in,
    json_output,
    params_from,
    print_json,
    seed,
)
from bbdyn.lyapunov import billiard_lyapunov, flat_lyapunov

HELP = (
    "Largest Lyapunov exponent of the billiard per attractor (all four: --spectrum; the flat "
    "ball's: --flat)"
)

#: ``--n``: at least 2 particles for a standard error.
n_type = integer_in("n", 2, 100_000, "the standard errors are over particles")
windows_type = integer_in("windows", 1, 1000, "the run is split into this many windows")
qr_every_type = integer_in("qr-every", 1, 20, "impact-to-impact events between two QR steps")


def add_arguments(parser) -> None:
    # the tangent dynamics is deterministic: no --eta
    add_model_arguments(parser, (*(o for o in BILLIARD_OPTIONS if o != "eta"), "g"))
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
    parser.add_argument(
        "--flat", action="store_true",
        help="the flat ball instead of the billiard (uses --f --A --alpha --g; default: off)",
    )  # fmt: skip
    parser.add_argument(
        "--spectrum", action="store_true",
        help="billiard: all four exponents of the section map, not only the largest "
        "(default: off)",
    )  # fmt: skip
    parser.add_argument(
        "--qr-every", type=qr_every_type, default=1,
        help="billiard --spectrum: impact-to-impact events between two QR steps "
        "(default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--no-classify", action="store_true",
        help="billiard: report the whole ensemble only, without classifying the attractors "
        "(default: off)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def lyapunov_summary(args) -> dict:
    """Run the exponents for ``args`` (billiard, or the flat ball with ``--flat``): the
    JSON object of the command."""
    clock = Clock()
    out = flat_summary(args) if args.flat else billiard_summary(args)
    return json_output(out, params=params_from(args).to_dict(), clock=clock, seed=args.seed)


def flat_summary(args) -> dict:
    """The flat ball's numbers with the window exponents (keys of the Python objects)."""
    if args.spectrum:
        raise ValueError("--spectrum is for the billiard; the flat ball (--flat) always has "
                         "both of its exponents: leave out --spectrum")  # fmt: skip
    params = params_from(args)
    res = flat_lyapunov(
        params, args.n, t=args.t, transient=args.transient, windows=args.windows, seed=args.seed
    )
    out = {"model": "flat", "f": args.f, "gamma": params.gamma}
    out.update(n=args.n, t=args.t)
    out.update(res.summary())
    out["window_cond_lam1_per_s"] = [float(x) for x in res.window_exponents()]
    if out["stuck_fraction"] > 0:
        out["note"] = "exponents -inf (null in JSON): a particle stuck, which forgets its state"
    return out


def billiard_summary(args) -> dict:
    """The billiard's numbers: the ensemble's, and each attractor's unless ``--no-classify``
    (keys of the Python objects)."""
    params = params_from(args)
    classified = not args.no_classify
    res = billiard_lyapunov(
        params, args.n, t=args.t, transient=args.transient, windows=args.windows,
        seed=args.seed, classify_attractors=classified, spectrum=args.spectrum,
        qr_every=args.qr_every,
    )  # fmt: skip
    out = {"model": "billiard", "f": args.f, "gamma": params.gamma}
    if args.spectrum:
        out["qr_every"] = args.qr_every
    out.update(t=args.t, transient=args.transient, per="attractor" if classified else "ensemble")
    out.update(res.summary())
    if classified:
        cls = res.meta["classification"]
        characters = [a["character"] for a in cls["attractors"]]
        out["attractors"] = [
            {**a, "character": characters[a["attractor"]]} for a in res.by_attractor()
        ]
        out["regime"] = cls["regime"]
        out["unsettled_fraction"] = cls["unsettled_fraction"]
    if out["collapse_fraction"] > 0:
        out["note"] = "exponent -inf (null in JSON): a particle stuck at a wedge"
    return out


def _pm(value: float, se: float, width: int = 0) -> str:
    """``value +- se`` (the value right-aligned in ``width``, the error in 7 characters); the
    value alone, padded alike, where the error is undefined (the exponent -inf of a collapse)."""
    import math

    if math.isnan(se):
        return f"{value:>{width}.5g}" + " " * (11 if width else 0)
    return f"{value:>{width}.5g} +- {se:<{7 if width else 0}.2g}"


def _billiard_lines(s: dict) -> list[str]:
    lines = [
        f"billiard, f = {s['f']:g} Hz (Gamma = {s['gamma']:.4f}), n = {s['n']}, "
        f"t = {s['t']:g} s after {s['transient']:g} s",
        f"{'':>30} {'lam1 (1/s)':>22} {'lam1 per collision':>24} {'collisions/s':>13}",
    ]
    groups = [("ensemble", s)] + [
        (f"attractor {a['attractor']} ({a['character']}, {a['fraction']:.2f})", a)
        for a in s.get("attractors", [])
    ]
    for name, g in groups:
        lines.append(
            f"{name:>30} {_pm(g['lam1_per_s'], g['lam1_per_s_se'], 12)}"
            f"{_pm(g['lam1_per_collision'], g['lam1_per_collision_se'], 14)}"
            f"{g['collision_rate']:>13.5g}"
        )
    if "regime" in s:
        lines.append(f"regime {s['regime']}, unsettled fraction {s['unsettled_fraction']:.2f}")
    windows = ", ".join(f"{x:.4g}" for x in s["window_cond_lam1_per_s"])
    lines.append(f"ensemble lam1 per window (1/s): {windows}")
    if "spectrum_per_s" in s:
        lines += _spectrum_lines(groups)
    return lines


def _spectrum_lines(groups) -> list[str]:
    """The whole spectrum of each group (``--spectrum``)."""
    lines = [
        "spectrum (lam1..lam4, 1/s; -inf: a direction a stick collapses), and between "
        "sticks; sum of the exponents per event against the closed-form log|det J|"
    ]

    def four(key: str, g: dict) -> str:
        return ", ".join(_pm(v, e) for v, e in zip(g[key], g[f"{key}_se"], strict=True))

    for name, g in groups:
        lam, free = four("spectrum_per_s", g), four("free_spectrum_per_s", g)
        lines += [
            f"{name:>30} spectrum: {lam}",
            f"{'':>30} between sticks: {free}",
            f"{'':>30} sum {_pm(g['spectrum_sum_per_event'], g['spectrum_sum_per_event_se'])}"
            f" vs closed form {_pm(g['log_det_per_event'], g['log_det_per_event_se'])}"
            f" per event; sticks {g['stick_event_fraction']:.3g} of the collisions, "
            f"stuck particles {g['stuck_fraction']:.2f}",
        ]
    return lines


def _flat_lines(s: dict) -> list[str]:
    lines = [
        f"flat ball, f = {s['f']:g} Hz (Gamma = {s['gamma']:.4f}), n = {s['n']}, t = {s['t']:g} s",
        f"stuck at least once: {s['stuck_fraction']:.3f} of the particles (exponent -inf)",
    ]
    for tag, unit in (("per_s", "1/s"), ("per_impact", "per impact")):
        for pre, what in (("", "exponents"), ("cond_", "conditional (between sticks)")):
            vals = [_pm(s[f"{pre}lam{i}_{tag}"], s[f"{pre}lam{i}_{tag}_se"]) for i in (1, 2)]
            lines.append(f"{what:>30} {unit:>10}: lam1 = {vals[0]}, lam2 = {vals[1]}")
    windows = ", ".join(f"{x:.4g}" for x in s["window_cond_lam1_per_s"])
    lines.append(f"conditional lam1 per window (1/s): {windows}")
    return lines


def warn_drift(s: dict) -> None:
    """One line on stderr when the window exponents disagree beyond their errors."""
    import sys

    if not s["windows_agree"]:
        print(f"bbdyn lyapunov: warning: the {s['window_dof'] + 1} windows' exponents disagree "
              f"beyond their errors (chi2 = {s['window_chi2']:.3g} for {s['window_dof']} dof, "
              f"p = {s['window_p']:.2g}): not converged, try a longer --transient or --t",
              file=sys.stderr)  # fmt: skip


def run(args) -> int:
    s = lyapunov_summary(args)
    warn_drift(s)
    if args.json:
        print_json(s)
        return 0
    print("\n".join(_flat_lines(s) if args.flat else _billiard_lines(s)))
    return 0
