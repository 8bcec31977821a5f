"""``python -m fic_teleop_experiments.e2``: the E2 command line (command_line.py)."""
import sys

from .command_line import main

sys.exit(main())
