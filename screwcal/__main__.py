"""`python -m screwcal`: the console script."""

import sys

from screwcal.commands.main import main

sys.exit(main())
