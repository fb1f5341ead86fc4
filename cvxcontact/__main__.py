"""``python -m cvxcontact``: the command line (:mod:`cvxcontact.apps.cli`)."""

import sys

from .apps.cli import main

if __name__ == "__main__":
    sys.exit(main())
