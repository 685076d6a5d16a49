"""``bbdyn reproduce [--quick|--medium|--full] [--out DIR] [--only ID ...]`` and
``bbdyn reproduce --docs [--only ID ...]``: scenes with an index page, or the figures of docs/."""

from bbdyn.commands import add_device_argument, add_setting_arguments, output_folder, seed
from bbdyn.scenes.reproduce import reproduce, reproduce_docs

HELP = "run every available scene and write figures, their data and an index page to a folder"


def add_arguments(parser) -> None:
    mode = add_setting_arguments(parser)
    mode.add_argument(
        "--docs",
        action="store_true",
        help="make the figures of docs/figures, each at its documented setting, and "
        "rewrite the figure table of docs/results.md (resumable)",
    )
    parser.add_argument(
        "--out", type=output_folder,
        help="output folder (default: out; not with --docs, which writes docs/figures)",
    )  # fmt: skip
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    add_device_argument(parser, "the scans of S3-S5 and B6")
    parser.add_argument(
        "--only", nargs="*", metavar="ID", help="only these scene ids (at least one)"
    )


def run(args) -> int:
    if args.docs:
        if args.out is not None:
            raise ValueError(
                f"--out {args.out} cannot be used with --docs, which writes into "
                "docs/figures of the source checkout; leave out --out or --docs"
            )
        page = reproduce_docs(
            only=args.only, seed=args.seed, progress=print, scan_progress=True, device=args.device
        )
    else:
        page = reproduce(
            out_dir=args.out or "out",
            setting=args.setting,
            seed=args.seed,
            only=args.only,
            progress=print,
            scan_progress=True,
            device=args.device,
        )
    print(f"index: {page}")
    return 0
