"""quadsim command-line entry: `python main.py --help`."""
import sys

from quadsim.cli import main

if __name__ == "__main__":
    sys.exit(main())
