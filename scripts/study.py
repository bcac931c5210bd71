#!/usr/bin/python3
"""scripts/cosim study KIND SCENARIO [options]: the studies of scripts/studies (see studies/cli.py)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from studies.cli import main  # noqa: E402 - after sys.path.insert (scripts/)

if __name__ == "__main__":
    main()
