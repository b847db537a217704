"""The robot's answer to a fall it could not prevent: it goes to the person, by a move that harms nobody.

Someone lying on the floor needs help, and a caregiving robot goes to them. It must not trip anyone still
walking on its way there: the poses beside the person
(:func:`~agents.caregiving.model.robot_moves.moves_beside`, nearest first) are judged as Algorithm 2's
moves are, in the joint imagination, with a :class:`~agents.caregiving.model.search_spec.SearchSpec` that
holds no danger, only the people walking. A pose is taken when the robot, driving there, keeps
:data:`KEEP_CLEAR` from everyone walking (a move made for no danger has no reason to pass near anyone, and
perception's error could make a near pass a touch), nobody falls who would not fall with the robot as it
is (it may be standing where it keeps someone from a fall), and nobody's sampled risk rises.
:func:`going_to` is that search as a protocol, asked as :mod:`agents.caregiving.model.response` asks its
searches.
"""

from __future__ import annotations

from collections.abc import Generator, Sequence
from dataclasses import replace

from .response import Ask, Asked
from .robot_moves import RobotMove
from .search_spec import SearchSpec
from .verdict import SearchResult

#: Metres between the robot and the body of the person it goes to: within reach, clear of their arms and legs.
GAP = 0.3
#: Metres the robot keeps from anyone walking on its way: out of arm's reach, and well beyond perception's error.
KEEP_CLEAR = 0.5


def going_to(spec: SearchSpec, moves: Sequence[RobotMove]) -> Generator[Ask, Asked, SearchResult | None]:
    """The search of ``moves`` with ``spec`` (which holds no danger), the robot kept :data:`KEEP_CLEAR` from
    everyone; its ``chosen`` is the first that harms nobody, if one does. None when the simulator refused it.

    No move is chosen for a risk it lowers, as there is none: only a safe move (clear, with a sampled risk
    under the threshold), or one that is clear where everyone walks their likeliest walk and, at the others,
    trips only people who fall with the robot as it is too.
    """
    return (yield Ask(replace(spec, keep_clear=KEEP_CLEAR), 0.0, tuple(moves))).found
