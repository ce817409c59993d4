"""``python3 -m retrofit.cli``: the ``retrofit`` command."""

import sys

from . import main

sys.exit(main())
