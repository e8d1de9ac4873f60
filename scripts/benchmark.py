"""Measure where the time goes (same as `hlcmp bench`): writes DIR/bench.json and prints a table.

python scripts/benchmark.py --out DIR [--quick]
"""

import sys

from hlcmp_drake.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
