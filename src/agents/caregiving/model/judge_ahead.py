"""A helper process that judges candidate moves while the search judges others.

Algorithm 2's search (:func:`agents.caregiving.model.move_search.search`) judges its
candidates in order and stops at the first safe one. On a machine with a second
core, once the first candidate has failed, it judges the next one in order itself
and lends the helper the ones after it, then reads the verdicts in candidate
order; after a head start is sent, the first verdict is read off the head
start's (:func:`~agents.caregiving.model.judging.driven_on`), so that happens
at once. Every candidate is judged with exactly the inputs it would have in a
lone search (scene, walks, the robot's start delay), so the verdicts and the
chosen move are those of the lone search; only the wall time differs.

The search keeps the helper two candidates deep, so that it is rarely idle while
this process judges. Verdicts the search no longer needs (it found a safe move
first) are read and dropped by the next search; until then they count against
the helper's depth, so a search never waits behind another's leftovers.

The helper is a plain process on a pipe, written and read by the calling thread
itself: no executor thread has to win the interpreter lock between the search's
steps to pass a candidate on.
"""

from __future__ import annotations

import multiprocessing
from collections import deque
from collections.abc import Hashable
from functools import partial
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING

from .robot_moves import RobotMove
from .scene import Scene
from .uncertainty import Uncertainty
from .verdict import Verdict

if TYPE_CHECKING:
    from .move_search import SearchSpec


class JudgeAhead:
    """One helper process (started and warmed at once) that judges lent moves in the order they were lent."""

    def __init__(self) -> None:
        context = multiprocessing.get_context("spawn")
        self._conn, child = context.Pipe()
        self._process = context.Process(target=_serve, args=(child,), name="judge-ahead", daemon=True)
        self._process.start()
        child.close()
        self._tags: deque[Hashable] = deque()  # the lent moves whose verdicts have not been read, oldest first
        self._alive = self._receive() is None  # the helper says it is ready, its model imported

    @property
    def pid(self) -> int | None:
        """The helper process's id."""
        return self._process.pid

    @property
    def outstanding(self) -> int:
        """How many lent moves the helper has not answered yet (or whose answers are unread)."""
        return len(self._tags)

    def lend(
        self, tag: Hashable, scene: Scene, spec: SearchSpec, move: RobotMove | None, uncertainty: Uncertainty
    ) -> bool:
        """Hand ``move`` over to be judged for ``spec``, its answer labelled ``tag``; False when the helper is gone."""
        if not self._alive:
            return False
        try:
            self._conn.send((scene, spec, move, uncertainty))
        except (OSError, ValueError):
            self._alive = False
            return False
        self._tags.append(tag)
        return True

    def answers(self, wait: bool = False) -> list[tuple[Hashable, Verdict | None]]:
        """The answers that have come back, oldest first; with ``wait``, at least one if any is outstanding.

        A None verdict means the helper could not judge that move (or is gone): judge it here instead.
        """
        out: list[tuple[Hashable, Verdict | None]] = []
        while self._tags and (wait and not out or self._ready()):
            answer = self._receive()
            if answer is False:
                out += [(tag, None) for tag in self._tags]
                self._tags.clear()
                break
            out.append((self._tags.popleft(), answer if isinstance(answer, Verdict) else None))
        return out

    def close(self) -> None:
        """Stop the helper, whatever it is doing."""
        self._alive = False
        self._conn.close()
        self._process.terminate()
        self._process.join(timeout=1.0)

    def _ready(self) -> bool:
        try:
            return self._conn.poll()
        except (EOFError, OSError):
            return True  # the next read reports the helper gone

    def _receive(self) -> object:
        """The next answer, or False when the helper is gone."""
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            self._alive = False
            return False


def _serve(conn: Connection) -> None:
    """The helper's loop: a verdict for every lent move, None for one it could not judge."""
    from .move_search import judge_move
    from .service import serve_one

    conn.send(None)
    while True:
        try:
            scene, spec, move, uncertainty = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        try:
            conn.send(judge_move(spec, move, partial(serve_one, scene), uncertainty, scene.robot_name))
        except Exception:  # the search judges the move itself and meets the error there
            conn.send(None)
