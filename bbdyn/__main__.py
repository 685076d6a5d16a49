"""``python -m bbdyn``: the ``bbdyn`` command line (``bbdyn.cli.main``)."""

import sys

from bbdyn.cli import main

if __name__ == "__main__":
    sys.exit(main())
