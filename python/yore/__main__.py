"""``python -m yore`` is the ``yore`` command."""

import sys

from ._entry import command

sys.exit(command())
