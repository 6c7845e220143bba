"""``python -m flexlift``: the same as the ``flexlift`` command."""

import sys

from flexlift.cli import main

sys.exit(main())
