"""``python -m yore`` is the ``yore`` command."""

import sys

from .cli import main

sys.exit(main())
