"""`bbdyn simulate --f F [--n N] [--t T] [--seed S] [--threads K] [--json]`: one ensemble run.

Prints the Einstein D with its standard error (late-window MSD slope), the
period-averaged energies, the stuck fraction and the collision rate of the
reference ensemble (MODEL.md section 3), with the parameters, seed, version
and wall time.
"""

HELP = "run the reference ensemble at one frequency and print D, energies, stuck fraction"


def add_arguments(parser) -> None:
    parser.add_argument("--f", type=float, required=True, help="driving frequency (Hz)")
    parser.add_argument("--n", type=int, default=1000, help="particles (default: 1000)")
    parser.add_argument("--t", type=float, default=200.0, help="simulated time in s (default: 200)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--transient", type=float, default=None, help="time discarded before averages (s; t/5)"
    )
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    for name, meaning in (
        ("A", "amplitude (mm)"),
        ("alpha", "normal restitution"),
        ("beta", "tangential restitution"),
    ):
        parser.add_argument(
            f"--{name}", type=float, default=None, help=f"{meaning}, MODEL.md default"
        )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--save", default=None, help="also save the result to SAVE.npz/.json")


def simulate_summary(args) -> dict:
    """Run the ensemble described by ``args`` and return the printed quantities."""
    from bbdyn import Params, __version__
    from bbdyn.diffusion import einstein_D_windows
    from bbdyn.ensemble import ensemble

    changes = {k: getattr(args, k) for k in ("A", "alpha", "beta") if getattr(args, k) is not None}
    params = Params(f=args.f, **changes)
    res = ensemble(
        params,
        n=args.n,
        t=args.t,
        seed=args.seed,
        transient=args.transient,
        threads=args.threads,
        observables=("displacement", "energy"),
    )
    if args.save:
        res.save(args.save)
    out = {"version": __version__, "params": params.to_dict(), "seed": args.seed}
    out.update(n=args.n, t=args.t, transient=res.meta["transient"], threads=res.meta["threads"])
    out.update(res.summary())
    centres, D_w, se_w = einstein_D_windows(res["sample_times"], res["displacement"])
    out["D_windows"] = {"t_centre": centres.tolist(), "D": D_w.tolist(), "D_se": se_w.tolist()}
    out["collisions"] = int(res["collisions"].sum())
    out["wall_s"] = res.meta["wall_s"]
    return out


def run(args) -> int:
    import json

    out = simulate_summary(args)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    p = out["params"]
    print(f"bbdyn {out['version']}  f = {p['f']} Hz  n = {out['n']}  t = {out['t']} s  "
          f"seed = {out['seed']}  (averages after {out['transient']:g} s)")  # fmt: skip
    print(f"  D              = {out['D']:.4g} +- {out['D_se']:.2g} mm^2/s")
    for name, unit in (("E", "kg mm^2/s^2"), ("E_x", ""), ("E_y", ""), ("E_pot", "")):
        print(f"  {name:<14} = {out[name]:.5g} +- {out[name + '_se']:.2g} {unit}")
    print(f"  A^2 w^2 / 2    = {out['E_reference']:.5g}")
    print(f"  stuck fraction = {out['stuck_fraction']:.4g}")
    print(f"  collisions     = {out['collisions_per_particle_per_s']:.5g} per particle per s")
    print("  D by window    = " + ", ".join(
        f"{d:.3g}+-{s:.2g}" for d, s in zip(out["D_windows"]["D"], out["D_windows"]["D_se"],
                                            strict=True)))  # fmt: skip
    print(f"  wall time      = {out['wall_s']:.2f} s on {out['threads']} thread(s)")
    return 0
