"""``bbdyn reproduce [--quick|--full] [--out DIR]``: every scene, with an index page."""

HELP = "run every available scene and write figures, their data and an index page to a folder"


def add_arguments(parser) -> None:
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", default=True, help="quick settings (default)")
    mode.add_argument("--full", action="store_true", help="full (reference paper) settings")
    parser.add_argument("--out", default="out", help="output folder (default: out)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument("--only", nargs="*", metavar="ID", help="only these scene ids")


def run(args) -> int:
    from bbdyn.reproduce import reproduce

    index = reproduce(
        out_dir=args.out, quick=not args.full, seed=args.seed, only=args.only, progress=print
    )
    print(f"index: {index}")
    return 0
