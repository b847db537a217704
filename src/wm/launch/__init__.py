"""``wm launch``: start, supervise and stop the processes of a launch file (docs/agents.md)."""
