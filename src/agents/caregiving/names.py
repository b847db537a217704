"""The caregiving vocabulary: the type names the agents, the world bridge and the experiment share.

They take type names from here, not from each other.
"""

from __future__ import annotations

# node types
WORLD = "world"  # the room, root of the RT tree
PERSON = "person"
ROBOT = "robot"
OBJECT = "object"
INTENTION = "intention"  # one of the robot's own intentions (its action)

# edge types
RT = "RT"  # declared by the base ontology: places the child in the parent's frame
HAS_INTENTION = "has_intention"  # person -> object they are guessed to walk to; `risky` when a collision is imagined
COLLISION = "collision"
KNOWS = "knows"  # person -> object they have surely seen and remember
HAS = "has"  # robot -> its intention; world -> agent
