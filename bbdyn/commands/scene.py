"""`bbdyn scene ID [--quick|--medium|--full] [--out DIR]`: draw one scene, save its numbers."""

from bbdyn.commands import seed

HELP = "compute and draw one scene (S1-S10, B1, B3-B6), saving its numbers beside the figure"


def add_arguments(parser) -> None:
    parser.add_argument("scene_id", metavar="ID", help="scene id, e.g. S1")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument(
        "--quick",
        dest="setting",
        action="store_const",
        const="quick",
        help="quick setting (default)",
    )
    mode.add_argument(
        "--medium",
        dest="setting",
        action="store_const",
        const="medium",
        help="medium setting (scenes that have one)",
    )
    mode.add_argument(
        "--full",
        dest="setting",
        action="store_const",
        const="full",
        help="full (reference paper) setting",
    )
    parser.set_defaults(setting="quick")
    parser.add_argument("--out", default="out", help="output folder (default: out)")
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")


def run(args) -> int:
    from bbdyn.scenes import run_scene

    result, png = run_scene(args.scene_id, setting=args.setting, out_dir=args.out, seed=args.seed)
    print(f"{args.scene_id.upper()}: {png} ({result.meta['scene_wall_s']:.1f} s)")
    return 0
