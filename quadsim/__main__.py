"""`python -m quadsim`: the command line."""

import sys

# first of all: quadsim.apps.launch takes SIGINT and SIGTERM before it imports anything else
from quadsim.apps.launch import main

if __name__ == "__main__":
    sys.exit(main())
