"""The imagine reply: one encoder, one strict decoder, the same message after a msgpack round trip."""

import math

import msgpack
import pytest

from agents.caregiving.model import imagine_reply
from agents.caregiving.model.errors import ReplyError
from agents.caregiving.model.imagine_reply import Answer, ImagineReply
from agents.caregiving.model.robot_moves import standoff_moves
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.service import serve_one

GAZE = math.radians(8)
UNCERTAINTY = {"size_error": 0.2, "sigma": {"ball": 0.02}, "samples": 16}


def reply() -> ImagineReply:
    scene = load_scenario("paper_experiment1").scene()
    walk = {"person": "person", "target": "couch", "gaze": GAZE}
    move = standoff_moves(scene, "ball")[0].to_wire()
    items = [
        {"kind": "person", **walk, "uncertainty": UNCERTAINTY},
        {"kind": "person", **walk},
        {"kind": "joint", "walks": [walk], "move": move, "uncertainty": UNCERTAINTY},
        {"kind": "fly"},
    ]
    return ImagineReply(3, scene.time, 1700000000.5, 12.5, tuple(serve_one(scene, i) for i in items))


def round_trip(r: ImagineReply) -> ImagineReply:
    return imagine_reply.decode(msgpack.unpackb(msgpack.packb(imagine_reply.encode(r))))


def test_a_reply_survives_the_wire() -> None:
    r = reply()
    person, no_risk, joint, failed = r.results
    assert person.imagination is not None and person.risk is not None and person.joint is None
    assert no_risk.imagination is not None and no_risk.risk is None
    assert joint.joint is not None and joint.risk is not None
    assert failed.error is not None and "kind" in failed.error
    assert round_trip(r) == r


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda w: w.pop("stamp"), "reply.stamp: is required"),
        (lambda w: w.update(episode=1.5), "reply.episode: expected a whole number"),
        (lambda w: w.update(extra=1), "reply.extra: unknown key"),
        (lambda w: w.update(results="none"), "reply.results: expected a list"),
        (lambda w: w["results"][0].update(kind="fly"), r"reply.results\[0\].kind: expected one of"),
        (lambda w: w["results"][0].pop("kind"), r"reply.results\[0\].kind: is required"),
        (lambda w: w["results"][0]["result"].update(path="here"), r"reply.results\[0\].result.path: expected a list"),
        (
            lambda w: w["results"][0]["risk"].update(probability=2.0),
            r"reply.results\[0\].risk.probability: expected at most",
        ),
        (lambda w: w["results"][3].pop("error"), r"reply.results\[3\].error: is required"),
    ],
)
def test_decoding_is_strict(change, message: str) -> None:
    wire = msgpack.unpackb(msgpack.packb(imagine_reply.encode(reply())))
    change(wire)
    with pytest.raises(ReplyError, match=message):
        imagine_reply.decode(wire)


def test_an_answer_holds_something() -> None:
    with pytest.raises(ValueError, match="an answer holds"):
        imagine_reply.encode_answer(Answer())
