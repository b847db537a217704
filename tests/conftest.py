"""Shared fixtures: the process helpers of tests/procs.py."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from procs import spawner  # noqa: F401
