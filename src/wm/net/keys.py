"""The Zenoh key-expression layout of cortex-wm (see ``docs/keys.md``).

``wm/<graph>/delta/<replica>``         DELTA messages of one replica (reliable, express)
``wm/<graph>/sv/<replica>``            HEARTBEAT messages (state vector, last seq)
``wm/<graph>/sync/<replica>``          queryable: SYNC_REQUEST -> SYNC_REPLY, ACK_REQUEST -> ACK_REPLY
``wm/<graph>/alive/<replica>/<agent>`` liveliness token: membership and the agent's name

Applications may add services of their own under ``wm/<graph>/`` (the caregiving
one: ``agents.caregiving.keys``).
"""

from __future__ import annotations

import re

from ..errors import ValidationError

ROOT = "wm"
_SEGMENT = re.compile(r"^[A-Za-z0-9_.\-]+$")


def check_segment(value: str, what: str) -> str:
    """A graph, replica or agent name must be one plain key segment."""
    if not isinstance(value, str) or not _SEGMENT.match(value):
        raise ValidationError(f"{what} {value!r} must be letters, digits, '_', '-' or '.' (one key segment)")
    return value


def delta(graph: str, replica: str = "*") -> str:
    return f"{ROOT}/{graph}/delta/{replica}"


def heartbeat(graph: str, replica: str = "*") -> str:
    return f"{ROOT}/{graph}/sv/{replica}"


def sync(graph: str, replica: str = "*") -> str:
    return f"{ROOT}/{graph}/sync/{replica}"


def alive(graph: str, replica: str = "*", agent: str = "*") -> str:
    return f"{ROOT}/{graph}/alive/{replica}/{agent}"


def replica_of(key: str) -> str:
    """The replica segment of a delta, sv, sync or alive key."""
    parts = key.split("/")
    return parts[3] if len(parts) > 3 else ""


def parse_alive(key: str) -> tuple[str, str]:
    """(replica, agent) of a liveliness key."""
    parts = key.split("/")
    if len(parts) != 5 or parts[0] != ROOT or parts[2] != "alive":
        raise ValidationError(f"not a liveliness key: {key!r}")
    return parts[3], parts[4]
