"""`python -m armtrack_cli.cli …` runs the command line."""

import sys

from armtrack_cli.cli import main

sys.exit(main())
