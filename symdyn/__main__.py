"""`python -m symdyn`: the command line, as `symdyn`."""

import sys

from .cli import main

sys.exit(main())
