"""`bbdyn simulate --f F [--A --alpha --beta --R --d --phi --eta] [--n N --t T --seed S]
[--fast-forward M] [--device D] [--json]`: one run.

Prints the Einstein D with its standard error (late-window MSD slope), the
period-averaged energies, the stuck fraction and the collision rate of the
reference ensemble (docs/model.md, section 3), with the parameters, seed, version
and wall time.  Progress is shown on stderr when it is a terminal (not with --json).

JSON keys (docs/schema.md): ``version``, ``params`` (f Hz, A mm, g mm/s^2, alpha, beta,
R mm, d mm, phi degrees, eta), ``seed``, ``gamma``, ``n``, ``t``, ``transient`` (s),
``threads``, ``fast_forward``, ``device``, ``device_name``; ``n_ok``, ``n_failed``,
``failures``; ``D``, ``D_se`` (mm^2/s); ``E``,
``E_x``, ``E_y``, ``E_pot``, ``E_reference`` with ``_se`` (kg mm^2/s^2);
``stuck_fraction`` (``_se``); ``collision_rate``, ``jump_rate`` (per particle, 1/s);
``v_d``, ``v_d_se`` (drift velocity, mm/s; D is about the drift when ``phi != 0``);
``D_windows`` (``t_centre`` s, ``D``, ``D_se``); ``collisions``; ``cpu_s``, ``wall_s`` (s);
``units`` (the unit of each dimensioned key).
"""

from bbdyn.commands import (
    Clock,
    add_device_argument,
    add_ensemble_arguments,
    add_model_arguments,
    add_save_argument,
    finite,
    json_output,
    params_from,
    print_json,
    run_progress,
    save_result,
)
from bbdyn.core.status import FAST_FORWARD_MODES
from bbdyn.diffusion import einstein_D_windows
from bbdyn.ensemble import ensemble

HELP = "run the reference ensemble at one frequency and print D, energies, stuck fraction"


def add_arguments(parser) -> None:
    add_model_arguments(parser)
    add_ensemble_arguments(parser, t=200.0)
    parser.add_argument(
        "--transient", type=finite, default=None, help="time discarded before averages "
        "(s; default: t/5)"
    )  # fmt: skip
    parser.add_argument(
        "--fast-forward", choices=FAST_FORWARD_MODES, default="converged",
        help="skip stick-release cycles once they repeat bit for bit (bitwise), also once "
        "converged to 1e-12 mm (converged, the default), or never (off); docs/billiard.md; "
        "never on a GPU"
    )  # fmt: skip
    add_device_argument(parser)
    add_save_argument(parser)


def simulate_summary(args) -> dict:
    """Run the ensemble described by ``args`` and return the printed quantities."""
    clock = Clock()
    params = params_from(args)
    bar = run_progress("simulate", args.t, args.json)
    res = ensemble(
        params,
        n=args.n,
        t=args.t,
        seed=args.seed,
        transient=args.transient,
        threads=args.threads,
        observables=("displacement", "energy"),
        fast_forward=args.fast_forward,
        progress=bar.update_fraction,
        device=args.device,
    )
    bar.close()
    if args.save:
        save_result(res, args.save, args.json)
    out = {"gamma": params.gamma, "n": args.n, "t": args.t, "transient": res.meta["transient"]}
    out["threads"] = res.meta["threads"]
    out["fast_forward"] = res.meta["fast_forward"]
    out["device"], out["device_name"] = res.meta["device"], res.meta["device_name"]
    out.update(res.summary())
    out["v_d"], out["v_d_se"] = (float(v) for v in res.drift())
    centres, D_w, se_w = einstein_D_windows(
        res["sample_times"], res["displacement"][res.ok], drift=params.phi != 0.0
    )
    out["D_windows"] = {"t_centre": centres.tolist(), "D": D_w.tolist(), "D_se": se_w.tolist()}
    out["collisions"] = int(res["collisions"].sum())
    return json_output(out, params=params.to_dict(), clock=clock, seed=args.seed)


def run(args) -> int:
    out = simulate_summary(args)
    if args.json:
        print_json(out)
        return 0
    p = out["params"]
    print(f"bbdyn {out['version']}  f = {p['f']} Hz  n = {out['n']}  t = {out['t']} s  "
          f"seed = {out['seed']}  (averages after {out['transient']:g} s)")  # fmt: skip
    print(f"  D              = {out['D']:.4g} +- {out['D_se']:.2g} mm^2/s")
    print(f"  v_d            = {out['v_d']:.4g} +- {out['v_d_se']:.2g} mm/s")
    for name, unit in (("E", "kg mm^2/s^2"), ("E_x", ""), ("E_y", ""), ("E_pot", "")):
        print(f"  {name:<14} = {out[name]:.5g} +- {out[name + '_se']:.2g} {unit}")
    print(f"  A^2 w^2 / 2    = {out['E_reference']:.5g}")
    print(f"  stuck fraction = {out['stuck_fraction']:.4g}")
    print(f"  collisions     = {out['collision_rate']:.5g} per particle per s")
    print("  D by window    = " + ", ".join(
        f"{d:.3g}+-{s:.2g}" for d, s in zip(out["D_windows"]["D"], out["D_windows"]["D_se"],
                                            strict=True)))  # fmt: skip
    print(f"  time           = {out['cpu_s']:.2f} s CPU, {out['wall_s']:.2f} s wall "
          f"on {out['threads']} thread(s)")  # fmt: skip
    return 0
