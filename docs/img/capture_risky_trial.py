"""Take the README's screenshot: ``wm view`` during the demo's risky trial, in headless Chromium.

    python docs/img/capture_risky_trial.py [--out docs/img/wm-view.png] [--rate R] [--scale S] [--attempts N]

1. Starts the caregiving stack of ``make demo`` (:func:`bridges.experiment.demo.demo_stack`:
   the world bridge listening on a free loopback port, the six agents connected to it,
   multicast scouting off).
2. Starts ``wm view`` for the same graph on a free loopback port, as one more child of
   the stack, and opens the page in headless Chromium (:mod:`wm.monitoring.chromium`).
3. Runs the demo's risky trial (:func:`bridges.experiment.demo.risky_trial`) on a thread and
   waits until the page shows a risky ``has_intention`` edge and the robot's ``intention``
   with its imagined final pose, and selects the risky edge so the inspector shows it.
   The page stops drawing at that state (its ``render`` becomes a no-op), so later poses
   cannot slip into the picture.
4. Takes the screenshot, lets the trial finish and prints what happened (it runs the
   trial again, up to ``--attempts`` times, if the page never showed both).
5. Stops Chromium, ``wm view`` and every process of the stack by PID.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

from rich.console import Console

from bridges.experiment.demo import RATE, demo_stack, narrate, risky_trial
from bridges.experiment.experiment import Scored
from wm.monitoring.chromium import Page, chromium

OUT = Path(__file__).resolve().parent / "wm-view.png"

#: Once the page shows a risky has_intention edge (with its collision point) and the robot's
#: intention (with its imagined final pose): select the edge for the inspector, stop drawing
#: later states (the page's ``render``; its websocket stays connected) and return the edge.
#: One evaluation, so nothing arrives in between. Else false.
FREEZE = """(() => {
  if (!state) return false;
  const risky = state.graph.edges.find(e => e.type === "has_intention" && e.attrs.risky === true && e.attrs.collision_point);
  const acted = state.graph.nodes.some(n => n.type === "intention" && n.attrs.final_pose);
  if (!(risky && acted && state.scene.cones.length && state.scene.ghosts.length)) return false;
  select("edge", [risky.src, risky.dst, risky.type]);
  render = () => {};
  return [risky.src, risky.dst, risky.type];
})()"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=OUT, help="the PNG to write")
    parser.add_argument("--rate", type=float, default=RATE, help="simulated seconds per second (the demo's by default)")
    parser.add_argument("--scale", type=float, default=1.0, help="device pixels per CSS pixel")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for the risky trial")
    parser.add_argument("--attempts", type=int, default=3, help="runs of the trial before giving up")
    args = parser.parse_args()
    console = Console()
    logs = Path(tempfile.mkdtemp(prefix="wm-capture-"))
    shot = None
    with demo_stack(logs, args.rate) as stack:
        console.print(f"stack on {stack.endpoint}, logs in {logs}")
        view = stack.add(
            "view",
            [
                sys.executable,
                "-m",
                "wm.cli",
                "view",
                "--graph",
                stack.graph,
                "--connect",
                stack.endpoint,
                "--host",
                "127.0.0.1",
                "--port",
                "0",
            ],
            "wm view: serving",
        )
        url = next(line for line in view.text().splitlines() if line.startswith("wm view: serving")).rsplit(" ", 1)[1]
        console.print(f"wm view on {url}")
        for attempt in range(1, args.attempts + 1):
            with chromium(url, scale=args.scale) as page:
                page.wait_for("document.getElementById('status').textContent === 'live'", 20, "the page to connect")
                with ThreadPoolExecutor(1, thread_name_prefix="risky-trial") as pool:
                    trial = pool.submit(risky_trial, stack, console)
                    shot = capture(page, trial, args.timeout)
            narrate(trial.result(), console)  # re-raises what the trial raised
            if shot is not None:
                break
            console.print(
                f"attempt {attempt}: the page never showed a risky intention and the robot's intention together"
            )
    if shot is None:
        sys.exit(f"no screenshot after {args.attempts} runs of the trial")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_bytes(shot)
    console.print(f"screenshot: {args.out}")


def capture(page: Page, trial: Future[Scored], timeout: float) -> bytes | None:
    """A screenshot of the page frozen at the first state showing the risky intention and the action."""
    deadline = time.monotonic() + timeout
    while not trial.done() and time.monotonic() < deadline:
        if page.eval(FREEZE):
            time.sleep(0.3)  # let the frame with the selection be painted
            return page.screenshot_png()
        time.sleep(0.02)
    return None


if __name__ == "__main__":
    main()
