"""`python -m armtrack_cli.cli …` runs the command line, as `armtrack` does."""

import sys

from armtrack_cli.__main__ import main

sys.exit(main())
