"""`python -m tsad_drake`: the `tsad` command."""

import sys

from tsad_drake.cli.main import main

sys.exit(main())
