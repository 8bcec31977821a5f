#!/usr/bin/env python3
"""Start, record, stop and report the teleoperation graph: the launcher of fic_teleop_bringup (what
scripts/run_teleop.sh runs; `--help` lists the options). Needs `source scripts/env.sh`."""
import sys

from fic_teleop_bringup.teleop_launcher import main

if __name__ == "__main__":
    sys.exit(main())
