"""Recorded batches of robot moves: written as served, read back, refused with a typed error when they are not."""

from pathlib import Path

import msgpack
import pytest
from recorded_cases import EXACT, HELD_OUT, THRESHOLD, recorded_case

from agents.caregiving.model import imagine_reply
from agents.caregiving.model.errors import RecordingError
from agents.caregiving.model.imagine_reply import ImagineReply
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.recorded_batch import read_batch, read_batches, write_batch
from agents.caregiving.model.service import serve_one


def test_a_batch_written_reads_back_and_serves_again_to_the_answer_sent(tmp_path: Path) -> None:
    _, _, scene, spec = recorded_case(HELD_OUT / "ward_footstool.yaml", 11, 9, 1.65)
    items = [SearchItem(spec, EXACT, THRESHOLD, 4).to_wire()]
    answers = tuple(serve_one(scene, item) for item in items)
    reply = imagine_reply.encode(ImagineReply(3, scene.time, None, 12.5, answers))
    for number in (2, 1):
        write_batch(tmp_path, number, scene, items, reply, 11.0 * number)
    batches = read_batches(tmp_path)
    assert [b.number for b in batches] == [1, 2] and batches[1].thread_ms == 22.0
    assert batches[0].scene == scene and batches[0].items == items
    assert batches[0].reply.results == answers == batches[0].serve_again()


def test_what_is_not_a_recorded_batch_is_refused_by_name(tmp_path: Path) -> None:
    bad = {
        "000001.msgpack": b"\xc1not msgpack",
        "000002.msgpack": msgpack.packb([1, 2]),
        "000003.msgpack": msgpack.packb({"request": {"items": []}, "reply": {}, "thread_ms": 1.0}),
        "000004.msgpack": msgpack.packb({"request": {"items": [{}]}, "reply": {"stamp": 0}, "thread_ms": -1}),
        "notanumber.msgpack": msgpack.packb({}),
    }
    for name, data in bad.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(RecordingError, match=name):
            read_batch(tmp_path / name)
    with pytest.raises(RecordingError, match="no such directory"):
        read_batches(tmp_path / "missing")
