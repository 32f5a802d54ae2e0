"""``python -m hbtp``."""

import sys

from hbtp.cli import main

sys.exit(main())
