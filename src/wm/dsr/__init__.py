"""``wm.dsr``: pydsr's API over a cortex-wm replica, so that a CORTEX agent moves over in one line.

::

    from wm.dsr import *          # was: from pydsr import *
    g = DSRGraph(0, "my_agent", 42)
    node = g.get_node("robot")
    node.attrs["robot_ref_adv_speed"] = Attribute(200.0, 42)
    g.update_node(node)           # writes only what this agent changed
    signals.connect(g, signals.UPDATE_NODE_ATTR, lambda id, names: print(id, names))

See docs/dsr.md for what changes for the better, and :mod:`wm.dsr.graph` for
where the replica connects.
"""

from . import signals
from .geometry import inner_api, rt_api
from .graph import DSRGraph
from .values import Attribute, DSRTypeError, DSRUnknownAttributeError, DSRUnknownTypeError, Edge, Node

__all__ = [
    "Attribute",
    "DSRGraph",
    "DSRTypeError",
    "DSRUnknownAttributeError",
    "DSRUnknownTypeError",
    "Edge",
    "Node",
    "inner_api",
    "rt_api",
    "signals",
]
