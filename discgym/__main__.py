"""``python -m discgym``: the discgym command line (see :mod:`discgym.cli`)."""

import sys

from .cli import main

sys.exit(main())
