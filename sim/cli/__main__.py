"""``python -m k37.sim.cli``: the ``k37`` command."""

import sys

from k37.sim.cli.main import main

sys.exit(main())
