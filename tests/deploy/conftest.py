"""Fixtures of the deploy tests (defined in deploy_helpers)."""

from deploy_helpers import other_pki, pki, sessions, spawn  # noqa: F401
