"""``python -m sim.cli``: the ``k37`` command."""

import sys

from sim.cli.main import main

sys.exit(main())
