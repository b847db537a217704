"""The caregiving vocabulary: the names of the types in ``ontology.yaml`` beside this module.

Agents, the world bridge and the experiment take type names from here, not from
each other. The ontology itself is :data:`ONTOLOGY_FILE`; it is installed as the
packaged ontology :data:`ONTOLOGY` (entry point group ``wm.ontologies``), so
``wm --ontology caregiving`` and ``wm.Ontology.named("caregiving")`` load it.
"""

from __future__ import annotations

from importlib import resources
from importlib.resources.abc import Traversable

ONTOLOGY = "caregiving"  # its name among the packaged ontologies
ONTOLOGY_FILE: Traversable = resources.files(__package__) / "ontology.yaml"

# node types
WORLD = "world"  # the room, root of the RT tree
PERSON = "person"
ROBOT = "robot"
OBJECT = "object"
INTENTION = "intention"  # one of the robot's own intentions (its action)
AGENT = "agent"  # declared by the base ontology; the agent runtime writes one per agent

# edge types
RT = "RT"  # declared by the base ontology: places the child in the parent's frame
HAS_INTENTION = "has_intention"  # person -> object they are guessed to walk to; `risky` when a collision is imagined
COLLISION = "collision"
KNOWS = "knows"  # person -> object they have surely seen and remember
HAS = "has"  # robot -> its intention; world -> agent
IN = "in"

# the robot's intentions (their `action`)
MOVE_TO = "move_to"  # drive to a pose to prevent a fall (Algorithm 2)
STOP = "stop"  # brake to a stop
GO_TO = "go_to"  # drive to someone who has fallen, to help
ALERT = "alert"  # someone has fallen: not a move, a call for help
MOVES = (MOVE_TO, STOP, GO_TO)  # the intentions the executor drives
PREVENTING = (MOVE_TO, STOP)  # the moves made against a danger: what the experiment times and scores

# what the experiment's reaction time measures: a risky HAS_INTENTION answered by a new INTENTION node
RISKY_EDGE = HAS_INTENTION
ACTION_NODE = INTENTION
