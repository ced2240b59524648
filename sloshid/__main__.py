"""`python -m sloshid` runs the command line."""

import sys

from sloshid.cli.app import main

sys.exit(main())
