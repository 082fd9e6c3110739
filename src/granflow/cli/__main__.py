"""``python -m granflow.cli``: the ``granflow`` command, for environments without the script."""

from granflow.cli import main

raise SystemExit(main())
