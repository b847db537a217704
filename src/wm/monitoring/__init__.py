"""Read-only views of a live graph: ``wm monitor``, ``wm view``, ``wm record``/``wm replay`` (docs/monitoring.md)."""
