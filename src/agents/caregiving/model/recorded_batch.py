"""Batches of robot moves as the simulator served them: one file each, read back to be served again offline.

With ``--record DIR`` the simulator writes every batch that judges robot moves (Algorithm 2's searches and
joint imaginations) to ``DIR/<n>.msgpack``, ``n`` counting on, in the order they were served, from the
highest already there (a directory used before keeps its batches): the request
with the scene it was served against pinned (so the file holds a request the service takes as it is), the
reply it sent, and the serving thread's CPU time. :func:`read_batches` reads a directory of them back, and
:meth:`RecordedBatch.serve_again` serves one again;
``bench/bench_replay_searches.py`` serves them again and compares.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgpack

from . import imagine_reply
from .errors import RecordingError
from .imagine_reply import Answer, ImagineReply
from .scene import Scene
from .service import HeadStart, Serving, batch_scene, serve_one

SUFFIX = ".msgpack"


@dataclass(frozen=True)
class RecordedBatch:
    """One batch as served: the scene it was served against, its items (in their wire form), its reply and the
    serving thread's CPU time (ms)."""

    number: int
    scene: Scene
    items: list[Any]
    reply: ImagineReply
    thread_ms: float

    def serve_again(self, head_start: HeadStart | None = None) -> tuple[Answer, ...]:
        """The batch's items served again here, in this process, as the simulator served them without a helper:
        a search asked for a head start looks for one, and hands it to ``head_start`` (if given) when found."""
        serving = Serving(head_start=head_start or (lambda lead: None))
        return tuple(serve_one(self.scene, item, serving) for item in self.items)


def last_number(directory: Path) -> int:
    """The highest number of a batch recorded in ``directory`` (0: none), so that a new one is numbered on."""
    return max((int(p.stem) for p in directory.glob(f"*{SUFFIX}") if p.stem.isdigit()), default=0)


def write_batch(
    directory: Path, number: int, scene: Scene, items: list[Any], reply: dict[str, Any], thread_ms: float
) -> Path:
    """Write one served batch (``reply`` in its wire form) as ``directory/<number>.msgpack``."""
    path = directory / f"{number:06d}{SUFFIX}"
    record = {"request": {"items": items, "scene": scene.to_wire()}, "reply": reply, "thread_ms": thread_ms}
    path.write_bytes(msgpack.packb(record, use_bin_type=True))
    return path


def read_batch(path: Path) -> RecordedBatch:
    """Read one file :func:`write_batch` wrote; raises :class:`RecordingError` when it is not one."""
    try:
        data = msgpack.unpackb(path.read_bytes(), raw=False, strict_map_key=False)
        if not isinstance(data, dict) or not isinstance(data.get("request"), dict):
            raise RecordingError("expected a map with a request")
        thread_ms = data.get("thread_ms")
        if not isinstance(thread_ms, int | float) or thread_ms < 0:
            raise RecordingError(f"thread_ms: expected a non-negative number, got {thread_ms!r}")
        scene, items = batch_scene(data["request"], None)
        return RecordedBatch(int(path.stem), scene, items, imagine_reply.decode(data.get("reply")), thread_ms)
    except (OSError, ValueError, msgpack.UnpackException) as exc:
        raise RecordingError(f"{path}: not a recorded batch: {exc}") from None


def read_batches(directory: Path) -> list[RecordedBatch]:
    """Every batch recorded in ``directory``, in the order they were served."""
    if not directory.is_dir():
        raise RecordingError(f"{directory}: no such directory")
    return sorted((read_batch(p) for p in directory.glob(f"*{SUFFIX}")), key=lambda b: b.number)
