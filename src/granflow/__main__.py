"""``python -m granflow``: the command line (see :mod:`granflow.cli`)."""

import sys

from granflow.cli.app import main

sys.exit(main())
