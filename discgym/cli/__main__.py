"""``python -m discgym.cli``: the discgym command line (``python -m discgym`` too)."""

import sys

from . import main

sys.exit(main())
