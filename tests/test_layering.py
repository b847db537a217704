"""wm stands alone: in a fresh venv holding only wm's own dependencies (pyproject's ``dependencies``),
``import wm``, ``wm --help`` and ``wm serve`` work, first with nothing of ``agents`` or ``bridges``
present, then with the project installed without its extras (the application's commands are plugins
that load, and running one says what is missing). The import contracts themselves are checked by
``lint-imports`` (make check).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from procs import REPO, endpoint, free_port

VENV_BUDGET_S = 60.0  # the fresh venv with wm's dependencies should take less; the test says when it does not


@dataclass
class Venv:
    root: Path
    python: Path
    seconds: float

    def bin(self, name: str) -> Path:
        return self.python.parent / name


def _run(
    argv: Sequence[str | Path], cwd: Path, env: dict[str, str] | None = None, timeout: float = 240
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(a) for a in argv],
        cwd=cwd,
        env={**os.environ, **(env or {})},
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _clean_env(**extra: str) -> dict[str, str]:
    """The environment without this test run's own venv and path."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    return {**env, "PYTHONUNBUFFERED": "1", **extra}


@pytest.fixture(scope="module")
def core_venv(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Venv]:
    """A fresh venv with wm's own dependencies only."""
    root = tmp_path_factory.mktemp("layering")
    started = time.monotonic()
    subprocess.run([sys.executable, "-m", "venv", str(root / "venv")], check=True, timeout=120)
    python = root / "venv" / "bin" / "python"
    deps = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"]
    done = _run([python, "-m", "pip", "install", "-q", "--disable-pip-version-check", *deps], cwd=root)
    assert done.returncode == 0, done.stderr
    seconds = time.monotonic() - started
    print(f"fresh venv with wm's dependencies: {seconds:.1f} s")
    yield Venv(root, python, seconds)


def _serve_starts(argv: Sequence[str | Path], cwd: Path, env: dict[str, str]) -> None:
    """``wm serve`` on a free loopback port prints its ready line; then it is stopped by its PID."""
    port = free_port()
    proc = subprocess.Popen(
        [str(a) for a in [*argv, "serve", "--data", cwd / "data", "--graph", "alone", "--listen", endpoint(port)]],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[str] = []
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 60
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("wm serve: ready") or time.monotonic() > deadline:
                break
        assert any(line.startswith("wm serve: ready") for line in lines), "".join(lines)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
    assert proc.returncode == 0, "".join(lines)


def test_the_venv_is_quick(core_venv: Venv) -> None:
    if core_venv.seconds > VENV_BUDGET_S:
        pytest.fail(
            f"creating the venv with wm's dependencies took {core_venv.seconds:.0f} s (budget {VENV_BUDGET_S:.0f} s)"
        )


def test_wm_alone_imports_serves_and_answers_help(core_venv: Venv) -> None:
    """Only src/wm on the path: no agents, no bridges, no entry points of the application."""
    alone = core_venv.root / "wm_alone"
    shutil.copytree(REPO / "src" / "wm", alone / "wm", ignore=shutil.ignore_patterns("__pycache__"))
    env = _clean_env(PYTHONPATH=str(alone))
    every_module = (
        "import importlib, importlib.util, pkgutil, wm\n"
        "assert importlib.util.find_spec('agents') is None and importlib.util.find_spec('bridges') is None\n"
        "for m in pkgutil.walk_packages(wm.__path__, 'wm.'): importlib.import_module(m.name)\n"
        "g = wm.Graph(); print(g.ontology.source, sorted(wm.Ontology.names()))\n"
    )
    done = _run([core_venv.python, "-c", every_module], cwd=core_venv.root, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[0] == "base", done.stdout  # no application: the neutral base is the default

    done = _run([core_venv.python, "-m", "wm.cli", "--help"], cwd=core_venv.root, env=env)
    assert done.returncode == 0, done.stderr
    assert "serve" in done.stdout and "experiment" not in done.stdout
    _serve_starts([core_venv.python, "-m", "wm.cli"], core_venv.root, env)


def test_the_project_without_extras_runs_wm_and_names_what_the_application_lacks(core_venv: Venv) -> None:
    """The project installed with --no-deps beside wm's dependencies: wm works, the plugins load."""
    source = core_venv.root / "project"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, source / name)
    shutil.copytree(REPO / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    done = _run(
        [core_venv.python, "-m", "pip", "install", "-q", "--disable-pip-version-check", "--no-deps", source],
        cwd=core_venv.root,
    )
    assert done.returncode == 0, done.stderr
    env = _clean_env()

    done = _run([core_venv.python, "-c", "import wm; print(wm.Graph().ontology.source)"], cwd=core_venv.root, env=env)
    assert done.returncode == 0 and done.stdout.strip() == "default", done.stderr
    done = _run([core_venv.bin("wm"), "--help"], cwd=core_venv.root, env=env)
    assert done.returncode == 0, done.stderr
    assert "experiment" in done.stdout and "reactions" in done.stdout and "unavailable" not in done.stdout

    done = _run([core_venv.bin("wm"), "experiment", "paper_experiment1", "--trials", "1"], cwd=core_venv.root, env=env)
    assert done.returncode == 1 and done.stderr.count("\n") == 1, done.stderr
    assert "No module named" in done.stderr and "cortex-wm[caregiving]" in done.stderr, done.stderr
    _serve_starts([core_venv.bin("wm")], core_venv.root, env)
