"""Where a person remembers the robot: the pose at which they last surely saw it.

The world's people remember a moving body where they last saw it, and look at it
again only once it has moved more than
:data:`~agents.caregiving.model.world_model.REPLAN_SHIFT` away from that pose
(:class:`~agents.caregiving.model.world_model.World`). A robot driving past
someone who does not look at it again is still planned around where it stood.
Algorithm 1 does not know a person's gaze, so it keeps the pose at which the robot
was last seen at every gaze of theirs, as it marks the objects they surely know
(:func:`~agents.caregiving.model.visibility.surely_seen`). The joint imagination then
starts each person from that memory (:attr:`Walk.robot_at`), not from where the robot
stands at the moment it is judged.
"""

from __future__ import annotations

from .geometry import moved_more_than
from .scene import PersonState, Pose, RobotState
from .visibility import gaze_classes, surely_seen
from .world_model import REPLAN_SHIFT


def remembered_robot(previous: Pose | None, person: PersonState, robot: RobotState) -> Pose | None:
    """Where ``person`` remembers ``robot`` after a look now, having remembered it at ``previous`` (``None``: not
    seen yet): where it stands, if it moved more than the re-plan shift from there and they surely see it."""
    body = robot.body()
    if previous is not None and not moved_more_than(robot.moved(*previous).body().shape, body.shape, REPLAN_SHIFT):
        return previous
    return robot.pose if robot.name in surely_seen(gaze_classes(person, [body])) else previous
