"""The built wheel, installed in a fresh venv, runs outside the source tree: ``wm serve``, an agent, an experiment.

Everything the installed code reads (scenarios, ontologies, the launch file) must come from the
package, so the processes run with the venv's interpreter, from an empty directory, and without the
source tree on their path.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from procs import REPO, Proc, endpoint, free_port

pytestmark = pytest.mark.timeout(900)


def _run(argv: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=_clean_env())
    assert done.returncode == 0, (
        f"{' '.join(argv)} failed ({done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    )
    return done


def _clean_env() -> dict[str, str]:
    """The environment without the source tree on the import path."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv with the project's wheel and the caregiving extra installed; its bin directory."""
    work = tmp_path_factory.mktemp("wheel")
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(work / "dist"), str(REPO)], work, 600)
    wheel = next((work / "dist").glob("cortex_wm-*.whl"))
    _run([sys.executable, "-m", "venv", str(work / "venv")], work, 120)
    bin_dir = work / "venv" / "bin"
    _run([str(bin_dir / "pip"), "install", "-q", f"{wheel}[caregiving]"], work, 600)
    return bin_dir


@pytest.fixture
def elsewhere(tmp_path: Path) -> Path:
    """An empty working directory outside the repository."""
    return tmp_path


def test_the_installed_packages_come_from_the_venv(venv: Path, elsewhere: Path) -> None:
    code = "import wm, agents.caregiving, bridges.experiment; print(wm.__file__, agents.caregiving.__file__)"
    out = _run([str(venv / "python"), "-c", code], elsewhere, 120).stdout
    assert str(REPO / "src") not in out and "site-packages" in out


def test_wm_serve_and_an_agent_run_from_the_wheel(venv: Path, elsewhere: Path, spawner: Callable[..., Proc]) -> None:
    ep = endpoint(free_port())
    serve = spawner(
        [str(venv / "wm"), "serve", "--graph", "home", "--data", str(elsewhere / "data"), "--listen", ep],
        name="serve",
        env=_clean_env(),
        cwd=elsewhere,
    )
    serve.wait_line("wm serve: ready", timeout=60)
    agent = spawner(
        [str(venv / "python"), "-m", "agents.caregiving.simulation", "--graph", "home", "--connect", ep],
        name="simulation",
        env=_clean_env(),
        cwd=elsewhere,
    )
    agent.wait_line("", timeout=60, contains=" running ")
    assert serve.popen.poll() is None and agent.popen.poll() is None


def test_a_one_trial_experiment_runs_from_the_wheel(venv: Path, elsewhere: Path) -> None:
    out = _run(
        [
            str(venv / "wm"),
            "experiment",
            "paper_experiment1",
            "--trials",
            "1",
            "--rate",
            "2",
            "--json",
            str(elsewhere / "result.json"),
        ],
        elsewhere,
        300,
    ).stdout
    assert "prevented" in out and (elsewhere / "result.json").is_file()
