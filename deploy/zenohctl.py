#!/usr/bin/env python3
"""Zenoh deployment tool of cortex-wm: render/check templates, run a router, smoke-test pub/sub.

    .venv/bin/python deploy/zenohctl.py {render,check,run,sub,put} ...

The same as ``python -m wm.zenoh_config``; see that module and docs/deploy.md.
"""

import sys

from wm.zenoh_config import main

if __name__ == "__main__":
    sys.exit(main())
