"""``python -m vectorid.cli ARGS`` is ``vectorid ARGS``."""

import sys

from .main import main

sys.exit(main())
