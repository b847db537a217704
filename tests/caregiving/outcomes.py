"""A fall as the world's outcome lists it, for tests of the experiment's figures."""

from __future__ import annotations

from typing import Any


def fall(
    person: str, time: float = 5.0, point: tuple[float, float] = (0.0, 0.0), obstacle: str = "ball"
) -> dict[str, Any]:
    """One entry of ``world/outcome``'s ``collisions``: who fell into what, when and where."""
    return {"time": time, "person": person, "obstacle": obstacle, "point": list(point)}
