"""``python -m fmuid.cli``: the ``fmuid`` command."""

import sys

from fmuid.cli import main

sys.exit(main())
