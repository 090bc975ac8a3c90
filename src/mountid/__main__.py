"""``python -m mountid``: the command line."""

import sys

from mountid.cli import main

sys.exit(main())
