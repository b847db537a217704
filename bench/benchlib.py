"""Shared pieces of the benchmark scripts: argument parsing, percentiles, JSON output, child processes."""

from __future__ import annotations

import argparse
import json
import os
import platform
import socket
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"


def parser(name: str, description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=name, description=description)
    p.add_argument(
        "--json", type=Path, default=RESULTS / f"{name}.json", help="where to write the figures (default: %(default)s)"
    )
    return p


def percentiles(values_ms: Sequence[float]) -> dict[str, float]:
    data = np.asarray(values_ms, dtype=float)
    return {
        "n": int(data.size),
        "p50_ms": round(float(np.percentile(data, 50)), 4),
        "p99_ms": round(float(np.percentile(data, 99)), 4),
        "mean_ms": round(float(data.mean()), 4),
        "max_ms": round(float(data.max()), 4),
    }


def write_json(path: Path, figures: dict[str, Any]) -> None:
    figures = {
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
        "when": time.strftime("%Y-%m-%dT%H:%M:%S"),
        **figures,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures, indent=2))
    print(f"wrote {path}")


def print_table(title: str, rows: Sequence[tuple[str, Any]]) -> None:
    print(title)
    width = max(len(label) for label, _ in rows)
    for label, value in rows:
        print(f"  {label:<{width}}  {value}")


def report_draws(title: str, path: Path, settings: dict[str, Any], found: dict[str, Any]) -> None:
    """Print a bench on drawn beliefs (its figures, then its lists of draws by trial: those lost, those that tripped
    someone, those where someone walked into the robot) and write them with its settings."""
    print_table(title, [(k, v) for k, v in found.items() if not k.endswith("_draws")])
    for k, v in found.items():
        if k.endswith("_draws"):
            print(f"{k.replace('_', ' ')}:", v)
    write_json(path, {**settings, **found})


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def endpoint(port: int) -> str:
    return f"tcp/127.0.0.1:{port}"


def spawn(args: Sequence[str]) -> subprocess.Popen[str]:
    """A child running this Python with ``args`` (stdin and stdout piped); the caller stops it by PID."""
    return subprocess.Popen(
        [sys.executable, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def read_line(child: subprocess.Popen[str], prefix: str) -> str:
    assert child.stdout is not None
    for line in child.stdout:
        if line.startswith(prefix):
            return line[len(prefix) :].strip()
    raise RuntimeError(f"child exited before printing {prefix!r}")
