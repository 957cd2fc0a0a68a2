"""quadsim command-line entry: `python main.py --help`."""

import sys

from quadsim.apps.launch import main

if __name__ == "__main__":
    sys.exit(main())
