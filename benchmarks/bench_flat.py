"""Flat-ball work-precision benchmark (SCENES.md B2): same as ``bbdyn bench flat``.

Usage: ``python benchmarks/bench_flat.py [--quick] [--json] [--out PNG]``.
"""

import argparse
import sys

from bbdyn.commands import bench

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=bench.HELP)
    bench.add_arguments(parser)
    sys.exit(bench.run(parser.parse_args(["flat", *sys.argv[1:]])))
