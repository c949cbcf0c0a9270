"""``python -m compare.sweep``: the ``sweep`` and ``report --sweep`` commands stand-alone."""

import sys

from compare.sweep.cli import main

if __name__ == "__main__":
    sys.exit(main())
