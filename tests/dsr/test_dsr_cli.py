"""`wm load` and `wm dump --format dsr` with real DSR scene files, against a running `wm serve`."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from procs import REPO, WM, endpoint, free_port

DATA = REPO / "tests" / "data" / "dsr"
GRAPH = "dsrcli"


def wm(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*WM, *args, "--graph", GRAPH], capture_output=True, text=True, timeout=60, cwd=REPO)


def test_a_real_dsr_scene_loads_dumps_as_dsr_and_a_wrong_type_is_one_line(spawner, tmp_path: Path) -> None:
    port = free_port()
    spawner(
        [
            *WM,
            "serve",
            "--data",
            str(tmp_path / "data"),
            "--graph",
            GRAPH,
            "--listen",
            endpoint(port),
            "--ontology",
            "dsr",
        ],
        name="serve",
    ).wait_line("wm serve: ready", 20)

    bad = json.loads((DATA / "autonomyLab_objects.simscene.json").read_text())
    bad["DSRModel"]["symbols"]["1"]["type"] = "world"
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    refused = wm("load", str(tmp_path / "bad.json"), "--ontology", "dsr", "--connect", endpoint(port))
    assert refused.returncode == 1 and refused.stderr.count("\n") == 1, refused.stderr
    assert "'world'" in refused.stderr and "--ontology default" in refused.stderr

    loaded = wm(
        "load", str(DATA / "autonomyLab_objects.simscene.json"), "--ontology", "dsr", "--connect", endpoint(port)
    )
    assert loaded.returncode == 0, loaded.stderr
    assert "loaded 41 nodes and 43 edges" in loaded.stdout

    dumped = wm("dump", "--format", "dsr", "--ontology", "dsr", "--connect", endpoint(port))
    assert dumped.returncode == 0, dumped.stderr
    symbols = json.loads(dumped.stdout)["DSRModel"]["symbols"]
    assert len(symbols) == 41 and sum(len(s["links"]) for s in symbols.values()) == 43
    assert symbols["201"]["attribute"]["path"] == {
        "type": 0,
        "value": "../../etc/viriato_base_concept_3/viriato_mesh.ive",
    }
    assert symbols["201"]["attribute"]["parent"] == {"type": 7, "value": "500"}
    original = json.loads((DATA / "autonomyLab_objects.simscene.json").read_text())["DSRModel"]["symbols"]
    assert symbols["1"]["links"][0]["linkAttribute"] == original["1"]["links"][0]["linkAttribute"]


def test_wm_set_reads_uint64_values_in_full() -> None:
    from wm import Ontology
    from wm.cli import parse_value

    dsr = Ontology.named("dsr")
    assert parse_value(dsr, "parent", str(2**64 - 1)) == 2**64 - 1
    assert parse_value(dsr, "test_uint64_vec_type", f"[0,{2**64 - 1}]") == [0, 2**64 - 1]
