"""`python -m quadsim`: the command line."""

import sys

from quadsim.apps.launch import main

if __name__ == "__main__":
    sys.exit(main())
