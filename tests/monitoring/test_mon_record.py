"""Recording, replay and dump-at-time round-trip to identical graphs; a recording cut by kill -9 still opens."""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

from mcap.reader import make_reader
from mon_helpers import GRAPH, RISKY_SCENE, SCENE_NAMES, dump_json, node_names, run_wm, served_scene

from foxglove_helpers import message_class
from procs import PYTHON, REPO, WM, wait_until
from wm.monitoring.recording_file import CHANGES, LOG, SCENE, TF, UPDATES, graph_at, iter_messages

REPLICA = str(REPO / "tests" / "replica_proc.py")


def test_record_replay_and_dump_at_time_round_trip(spawner, tmp_path: Path) -> None:
    where = served_scene(spawner, tmp_path / "data", "copy")
    recording = tmp_path / "run.mcap"
    logs = tmp_path / "logs"
    logs.mkdir()
    recorder = spawner(
        [*WM, "record", str(recording), "--graph", GRAPH, "--connect", where, "--logs", str(logs)], name="record"
    )
    recorder.wait_line("wm record: recording", 20)
    (logs / "perception.log").write_text("2026-11-23T14:25:02.276Z INFO agent=perception alice seen\n")
    run_wm("set", "alice", "speed=0.9", "--connect", where)
    run_wm("rm", "ball", "--connect", where)
    final = dump_json(where)
    wait_until(lambda: graph_at(recording).to_dict() == final, 20, "the recording to hold the final graph")
    recorder.stop()
    assert recorder.wait_line("wm record:", 5)

    # wm dump --from FILE --at T, at the moments the JSON change channel shows
    changes = [(t, json.loads(data)) for _, t, data in iter_messages(recording, [CHANGES])]
    start = next(t for _, t, _ in iter_messages(recording))
    speed_at = next(t for t, c in changes if c["name"] == "alice" and c["attrs"].get("speed") == 0.9)
    removed_at = next(t for t, c in changes if c["kind"] == "node_removed" and c["name"] == "ball")

    def dump_at(t_ns: int) -> dict:
        return json.loads(
            run_wm("dump", "--from", str(recording), "--at", f"{(t_ns - start) / 1e9:.9f}", "--format", "json")
        )

    before, after_set, after_rm = dump_at(speed_at - 1000), dump_at(speed_at + 1000), dump_at(removed_at + 1000)
    assert node_names(before) == node_names(after_set) == SCENE_NAMES
    assert _attr(before, "alice", "speed") == 0.5 and _attr(after_set, "alice", "speed") == 0.9
    assert after_rm == final and "ball" not in node_names(after_rm)
    assert json.loads(run_wm("dump", "--from", str(recording), "--format", "json")) == final

    # the file is plain MCAP: indexed, with the channels of a live `wm foxglove` view
    with open(recording, "rb") as f:
        summary = make_reader(f).get_summary()
    schemas = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values() if c.schema_id}
    assert {topic: schema.name for topic, schema in schemas.items()} == {
        SCENE: "foxglove.SceneUpdate",
        TF: "foxglove.FrameTransforms",
        CHANGES: "wm.GraphChange",
        UPDATES: "wm.Update",
        LOG: "foxglove.Log",
    }
    scene_update = message_class("foxglove.SceneUpdate", schemas[SCENE].data)
    scenes = [scene_update.FromString(data) for _, _, data in iter_messages(recording, [SCENE])]
    assert any(e.id.startswith("path/") and e.lines[0].color.r > 0.8 for e in scenes[-1].entities)
    frame_transforms = message_class("foxglove.FrameTransforms", schemas[TF].data)
    last_tf = [frame_transforms.FromString(data) for _, _, data in iter_messages(recording, [TF])][-1]
    assert {(t.parent_frame_id, t.child_frame_id) for t in last_tf.transforms} >= {("world", "alice")}
    log = message_class("foxglove.Log", schemas[LOG].data)
    assert [(m.name, m.message) for m in map(log.FromString, (d for _, _, d in iter_messages(recording, [LOG])))] == [
        ("perception", "agent=perception alice seen")
    ]

    # wm replay into another graph gives the same graph there
    out = run_wm("replay", str(recording), "--as", "copy", "--speed", "50", "--connect", where)
    assert "republished into 'copy'" in out
    assert dump_json(where, graph="copy") == final


def test_recording_killed_mid_file_opens_and_keeps_all_but_the_last_second(spawner, tmp_path: Path) -> None:
    where = served_scene(spawner, tmp_path / "data")
    recording = tmp_path / "cut.mcap"
    recorder = spawner([*WM, "record", str(recording), "--graph", GRAPH, "--connect", where], name="record")
    recorder.wait_line("wm record: recording", 20)
    spawner([PYTHON, REPLICA, "--graph", GRAPH, "--connect", where, "--nodes", "5000", "--pace", "0.01"], name="writer")
    wait_until(lambda: len(node_names(dump_json(where))) > len(SCENE_NAMES) + 20, 30, "the writer to be writing")
    confirmed = node_names(dump_json(where))
    time.sleep(1.0)  # what the served graph held a second before the kill must be in the file
    recorder.kill9()
    kept = node_names(graph_at(recording).to_dict())
    assert confirmed <= kept, sorted(confirmed - kept)[:10]
    assert len(kept) < 5000 + len(SCENE_NAMES), "the writer had finished: the kill was not mid-run"


def _attr(graph: dict, name: str, attr: str):
    return next(n for n in graph["nodes"] if n["name"] == name)["attrs"].get(attr)


def test_reaction_times_pair_each_risky_intention_with_the_next_action(tmp_path: Path) -> None:
    import wm
    from bridges.experiment.reactions import plot_svg, reactions, summary
    from wm.monitoring.recorder import Recorder
    from wm.monitoring.recording_file import RecordingWriter

    g = wm.Graph()
    writer = RecordingWriter(tmp_path / "trial.mcap", "t")
    Recorder(g, writer)
    g.load_json(RISKY_SCENE)  # alice -> couch turns risky (after the scene's own intention node)
    g.insert_node("person", "bob")
    g.insert_or_assign_edge("bob", "table", "has_intention", {"risky": True})
    g.insert_node("intention", "robot_move_again", {"action": "move_to"})  # answers both
    g.insert_node("person", "carol")
    g.insert_or_assign_edge("carol", "ball", "has_intention", {"risky": True})  # never answered
    writer.close()
    found = reactions(tmp_path / "trial.mcap")
    assert [(r.person, r.target, r.action) for r in found] == [
        ("alice", "couch", "robot_move_again"),
        ("bob", "table", "robot_move_again"),
        ("carol", "ball", None),
    ]
    assert found[0].reaction_ms >= 0 and summary(found)["missed"] == 1
    assert plot_svg(found).startswith("<svg") and "missed 1" in plot_svg(found)
    out = subprocess.run(
        [*WM, "reactions", str(tmp_path / "trial.mcap"), "--json"], capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0 and json.loads(out.stdout)["missed"] == 1


def test_reactions_of_a_file_that_is_no_recording_is_a_one_line_error(tmp_path: Path) -> None:
    bogus = tmp_path / "notes.mcap"
    bogus.write_text("not a recording")
    out = subprocess.run([*WM, "reactions", str(bogus)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and out.stderr.strip().count("\n") == 0
    assert "is not an MCAP recording" in out.stderr
