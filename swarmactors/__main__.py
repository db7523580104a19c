import sys

from swarmactors.cli import main

sys.exit(main())
