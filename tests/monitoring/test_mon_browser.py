"""``wm view`` in real headless Chromium: the page shows a live graph, follows changes, inspects."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mon_helpers import SCENE_NAMES, run_wm, served_scene, start_view

from procs import REPO
from wm.monitoring.chromium import CHROMIUM, available, chromium

ARTIFACTS = REPO / "artifacts"
GRAPH_NAMES = "JSON.stringify([...document.querySelectorAll('#graph .gnode')].map(e => e.dataset.name).sort())"
SCENE_BODIES = "JSON.stringify([...document.querySelectorAll('#scene .body')].map(e => e.dataset.name).sort())"


def js_names(names: set[str]) -> str:
    """A JavaScript string literal equal to ``JSON.stringify`` of the sorted names."""
    return json.dumps(json.dumps(sorted(names), separators=(",", ":")))


def test_page_shows_the_live_graph_and_follows_changes(spawner, tmp_path: Path) -> None:
    if not available():
        pytest.skip(
            f"{CHROMIUM} is missing: `make system-deps` installs Debian's chromium and chromium-driver (needs root)"
        )
    where = served_scene(spawner, tmp_path / "data")
    _, url = start_view(spawner, where)
    with chromium(url) as page:
        page.wait_for(f"{GRAPH_NAMES} === {js_names(SCENE_NAMES)}", 30, "the graph view to show every node")
        placed = json.loads(page.eval(SCENE_BODIES))
        assert set(placed) == SCENE_NAMES - {"world", "robot_move_to_ball"}  # the RT tree, drawn in world's frame
        assert page.eval("document.querySelectorAll('#scene .path.risky').length") == 1
        assert page.eval("document.querySelectorAll('#scene .fov').length") == 1
        assert page.eval("document.querySelectorAll('#scene .ghost').length") == 1
        assert page.eval("document.querySelectorAll('#scene .collision').length") == 2

        page.eval("document.querySelector('#graph .gnode[data-name=\"alice\"]').dispatchEvent(new MouseEvent('click'))")
        page.wait_for(
            "document.getElementById('inspector').textContent.includes('fov')", 10, "the inspector to show alice"
        )
        page.screenshot(ARTIFACTS / "wm-view.png")

        run_wm("set", "alice", "speed=0.9", "--connect", where)
        page.wait_for(
            "document.getElementById('inspector').textContent.includes('0.9')", 20, "the inspector to follow the change"
        )
        run_wm("rm", "ball", "--connect", where)
        page.wait_for(f"{GRAPH_NAMES} === {js_names(SCENE_NAMES - {'ball'})}", 20, "the removed node to leave the page")
        assert "ball" not in json.loads(page.eval(SCENE_BODIES))
        page.screenshot(ARTIFACTS / "wm-view-after-change.png")
