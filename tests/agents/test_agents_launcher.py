"""``wm launch`` with plain processes: restart policies, start order, stop escalation, exit status, --check."""

from __future__ import annotations

from pathlib import Path

from launch_helpers import python_cmd, run_wm, start_launch

from procs import REPO, wait_until

SLEEPER = "import time; print('up', flush=True); time.sleep(600)"
STUBBORN = (
    "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); print('up', flush=True); time.sleep(600)"
)


def write(tmp: Path, text: str) -> Path:
    file = tmp / "launch.toml"
    file.write_text(text)
    return file


def test_a_failed_process_with_restart_never_ends_the_launch_with_status_1(spawner, tmp_path: Path) -> None:
    file = write(
        tmp_path,
        f"""
[[process]]
name = "fails"
cmd = {python_cmd("import sys; print('giving up', flush=True); sys.exit(3)")}
restart = "never"
""",
    )
    launch = start_launch(spawner, file, tmp_path / "logs")
    assert launch.finish(stop=False) == 1
    assert launch.status()["fails"]["state"] == "failed"
    assert launch.status()["fails"]["failures"] == ["exited with status 3"]
    assert "fails  | giving up" in launch.proc.output()
    assert "giving up" in launch.log("fails")


def test_restart_always_with_backoff_then_a_clean_stop_is_status_0(spawner, tmp_path: Path) -> None:
    file = write(
        tmp_path,
        f"""
[defaults]
backoff = {{ initial = 0.05, factor = 2.0, max = 0.2 }}

[[process]]
name = "first"
cmd = {python_cmd("import time; time.sleep(0.3); print('ready now', flush=True); time.sleep(600)")}
ready = "ready now"

[[process]]
name = "blinks"
cmd = {python_cmd("print('blink', flush=True)")}
restart = "always"
""",
    )
    launch = start_launch(spawner, file, tmp_path / "logs")
    launch.wait("blinks", lambda p: p["restarts"] >= 3, "three restarts")
    output = launch.proc.output()
    assert output.index("first  | ready now") < output.index("blinks: started")
    assert "restarting in 0.05 s" in output and "restarting in 0.1 s" in output
    assert launch.finish() == 0
    assert "every process stopped cleanly" in launch.proc.output()
    assert launch.log("blinks").count("blink\n") >= 3


def test_a_process_that_ignores_sigterm_is_killed_and_counted_as_a_failure(spawner, tmp_path: Path) -> None:
    file = write(
        tmp_path,
        f"""
stop_timeout = 0.5

[[process]]
name = "polite"
cmd = {python_cmd(SLEEPER)}

[[process]]
name = "stubborn"
cmd = {python_cmd(STUBBORN)}
""",
    )
    launch = start_launch(spawner, file, tmp_path / "logs")
    stubborn = launch.pid("stubborn")
    wait_until(lambda: "stubborn | up" in launch.proc.output(), 30, "stubborn to ignore SIGTERM")
    assert launch.finish() == 1
    assert "stubborn: did not stop within 0.5 s of SIGTERM; killed" in launch.proc.output()
    assert launch.status()["polite"]["failures"] == []
    assert not Path(f"/proc/{stubborn}").exists()


def test_check_names_every_bad_key_and_starts_nothing(tmp_path: Path) -> None:
    file = write(
        tmp_path,
        """
colour = "blue"

[vars]
graph = "g"

[[process]]
name = "a"
module = "agents.caregiving.perception"
args = ["--graph", "${graph}", "--connect", "${router}"]
restart = "sometimes"

[[process]]
module = "not a module"

[[process]]
name = "a"
cmd = ["surely-no-such-program-here"]
module = "x"
backoff = { initial = -1, jitter = 2 }
""",
    )
    result = run_wm("launch", "--check", str(file), check=False)
    assert result.returncode == 1
    errors = result.stderr
    for expected in (
        "colour: unknown key",
        "process.a.args[3]: undefined variable ${router}",
        "process.a.restart: must be one of never, on-failure, always, got 'sometimes'",
        "process[1].name: required",
        "process[1].module: must be a dotted module name",
        "process.a.name: duplicate process name",
        "process.a: give exactly one of cmd (a program) or module",
        "process.a.backoff.initial: must be a number >= 0",
        "process.a.backoff.jitter: unknown key",
    ):
        assert expected in errors, f"{expected!r} not in:\n{errors}"
    assert all(line.startswith(f"wm launch: error: {file}: ") for line in errors.splitlines())
    assert not (REPO / "logs" / "launch").exists()


def test_check_accepts_the_shipped_launch_files_without_importing_their_modules() -> None:
    files = sorted((REPO / "deploy" / "launch").glob("*.toml"))
    assert files
    for file in files:
        result = run_wm("launch", "--check", str(file), check=False)
        assert result.returncode == 0, result.stderr
        assert result.stdout.startswith(f"{file}: ok, ")
