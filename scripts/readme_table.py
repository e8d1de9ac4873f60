"""What the sweep scripts share: print the markdown table a sweep makes and, with
--update-readme, write it into its README block."""

import argparse
from pathlib import Path

from hlcmp_drake.present.report import write_block

README = Path(__file__).resolve().parent.parent / "README.md"


def main(description, make_table, block):
    """Parse --update-readme, make the table, print it, and write it into `block` if asked."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--update-readme", action="store_true")
    args = parser.parse_args()
    table = make_table()
    print(table)
    if args.update_readme:
        write_block(README, block, table)
