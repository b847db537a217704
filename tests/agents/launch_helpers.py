"""Helpers of the agent tests: launch files of probe agents, a running ``wm launch``, graph reads.

Processes are started through the ``spawner`` fixture of tests/procs.py, so
each is stopped by its PID at teardown.
"""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from procs import PYTHON, REPO, WM, Proc, wait_until

AGENTS_TESTS = Path(__file__).resolve().parent
PROBE = AGENTS_TESTS / "probe_agent.py"
PROBE_PATH = os.pathsep.join(p for p in (str(AGENTS_TESTS), os.environ.get("PYTHONPATH", "")) if p)


def probe_stack(graph: str, endpoint: str, agents: Sequence[str], data_dir: Path | None, log_dir: Path) -> str:
    """A launch file: ``wm serve`` as the router at ``endpoint`` (unless ``data_dir`` is None), then probe agents as its clients."""
    lines = [
        f'log_dir = "{log_dir}"',
        f'[vars]\ngraph = "{graph}"\nrouter = "{endpoint}"',
        f'[defaults]\nrestart = "on-failure"\nbackoff = {{ initial = 0.1 }}\nenv = {{ PYTHONPATH = "{PROBE_PATH}" }}',
    ]
    if data_dir is not None:
        lines.append(
            '[[process]]\nname = "serve"\nmodule = "wm.cli"\nrestart = "always"\nready = "wm serve: ready"\n'
            f'args = ["serve", "--data", "{data_dir}", "--graph", "${{graph}}", "--listen", "${{router}}"]'
        )
    for agent in agents:
        lines.append(
            f'[[process]]\nname = "{agent}"\nmodule = "probe_agent"\n'
            f'args = ["--graph", "${{graph}}", "--connect", "${{router}}", "--mode", "client", "--name", "{agent}", "--tag", "{agent}"]'
        )
    return "\n\n".join(lines) + "\n"


class Launch:
    """A running ``wm launch`` and what it reports in ``<log dir>/status.json``."""

    def __init__(self, proc: Proc, log_dir: Path) -> None:
        self.proc = proc
        self.log_dir = log_dir

    def status(self) -> dict[str, dict[str, Any]]:
        try:
            data = json.loads((self.log_dir / "status.json").read_text())
        except (OSError, json.JSONDecodeError):
            return {}
        return {p["name"]: p for p in data["processes"]}

    def wait(
        self, name: str, condition: Callable[[dict[str, Any]], bool], what: str, timeout: float = 30
    ) -> dict[str, Any]:
        wait_until(lambda: name in self.status() and condition(self.status()[name]), timeout, f"{name}: {what}")
        return self.status()[name]

    def pid(self, name: str) -> int:
        return int(self.wait(name, lambda p: p["state"] == "up" and p["pid"], "to be up")["pid"])

    def finish(self, stop: bool = True, timeout: float = 60) -> int:
        """Stop the launcher by SIGTERM (or wait for it to end) and read its output to the end; its exit status."""
        returncode = self.proc.stop(timeout) if stop else self.proc.popen.wait(timeout)
        last = ("every process stopped cleanly", "failures in: ")
        wait_until(
            lambda: any(text in line for line in self.proc.lines[-1:] for text in last), 10, "the launcher's last line"
        )
        assert returncode is not None
        return returncode

    def log(self, name: str) -> str:
        return (self.log_dir / f"{name}.log").read_text()


def start_launch(
    spawner: Callable[..., Proc], file: Path, log_dir: Path, *args: str, argv: Sequence[str] = ()
) -> Launch:
    """``wm launch FILE`` (prefixed by ``argv``, e.g. ``ip netns exec NS``), without the live table."""
    proc = spawner(
        [*argv, *WM, "launch", str(file), "--no-table", "--log-dir", str(log_dir), *args], name=f"launch {file.name}"
    )
    return Launch(proc, log_dir)


def run_wm(*args: str, argv: Sequence[str] = (), check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run([*argv, *WM, *args], capture_output=True, text=True, timeout=60, cwd=REPO, check=False)
    if check:
        assert result.returncode == 0, f"wm {' '.join(args)}: {result.stderr}"
    return result


def read_graph(graph: str, endpoint: str, argv: Sequence[str] = ()) -> dict[str, Any]:
    """The graph as ``wm dump --format json`` reads it from the network ({} when nothing answers)."""
    result = run_wm(
        "dump", "--format", "json", "--graph", graph, "--connect", endpoint, "--timeout", "2", argv=argv, check=False
    )
    return json.loads(result.stdout) if result.returncode == 0 else {}


def members(graph: str, endpoint: str, argv: Sequence[str] = ()) -> dict[str, str]:
    """Replica id -> agent name, as ``wm members`` lists them ({} when nothing answers)."""
    result = run_wm("members", "--graph", graph, "--connect", endpoint, argv=argv, check=False)
    return dict(line.split() for line in result.stdout.splitlines()) if result.returncode == 0 else {}


def agent_nodes(graph: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {n["name"]: n["attrs"] for n in graph.get("nodes", []) if n["type"] == "agent"}


def load_nodes(tmp: Path, graph: str, endpoint: str, *nodes: tuple[str, str], argv: Sequence[str] = ()) -> None:
    """Insert nodes ``(type, name)`` with ``wm load`` (fresh ids), through a scene file in ``tmp``."""
    scene = {
        "format": "cortex-wm",
        "version": 1,
        "edges": [],
        "nodes": [{"id": i + 1, "type": t, "name": n, "attrs": {}} for i, (t, n) in enumerate(nodes)],
    }
    path = tmp / f"scene-{nodes[0][1]}.json"
    path.write_text(json.dumps(scene))
    run_wm("load", str(path), "--new-ids", "--graph", graph, "--connect", endpoint, argv=argv)


def python_cmd(code: str) -> str:
    """A ``cmd`` value (TOML array) running ``python -c CODE``."""
    return json.dumps([PYTHON, "-c", code])
