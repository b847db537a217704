"""Size caps and value rules shared by local writes and by the view of remote content.

A value is checked twice with the same rules: when a local write is made
(:meth:`wm.Ontology.check_attrs`) and when a remote one is read into the view
(:mod:`wm.view_rules`). The caps belong to the ontology (its ``limits:``
section, docs/ontology.md) because every replica must apply the same ones to
build the same graph from the same document.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

FLOAT_BYTES = 8  # a vec element travels as a float64
CONFLICT_SUFFIX_ROOM = 17  # "~" and up to 16 digits of an id: what a name conflict adds (wm.Graph._rename_losers)


@dataclass(frozen=True)
class Limits:
    """Caps no robot hits in normal use; configurable in the ontology file."""

    max_value_bytes: int = 1_000_000  # a str (UTF-8), bytes, or a vec (8 bytes an element)
    max_name_length: int = 256  # characters of a node name

    def __post_init__(self) -> None:
        if self.max_value_bytes < 1:
            raise ValueError(f"max_value_bytes must be positive, got {self.max_value_bytes}")
        if self.max_name_length <= CONFLICT_SUFFIX_ROOM:
            raise ValueError(
                f"max_name_length must leave room for a conflict suffix (> {CONFLICT_SUFFIX_ROOM}), "
                f"got {self.max_name_length}"
            )

    def size_problem(self, value: Any) -> str | None:
        """Why a canonical value (str, bytes or a tuple of floats) is too large or not encodable, or None."""
        if isinstance(value, str):
            try:
                size = len(value) if value.isascii() else len(value.encode("utf-8"))
            except UnicodeEncodeError:
                return "a str with a lone surrogate cannot be stored"
        elif isinstance(value, (bytes, bytearray)):
            size = len(value)
        elif isinstance(value, tuple):
            size = len(value) * FLOAT_BYTES
        else:
            return None
        if size > self.max_value_bytes:
            return f"{size} bytes exceeds the limit of {self.max_value_bytes} bytes per value"
        return None

    def name_problem(self, name: Any) -> str | None:
        """Why ``name`` cannot be a node name, or None."""
        if not isinstance(name, str) or not name or name.startswith("@"):
            return "a node name must be a non-empty str not starting with '@'"
        if len(name) > self.max_name_length:
            return f"a node name of {len(name)} characters exceeds the limit of {self.max_name_length}"
        if not name.isascii():
            try:
                name.encode("utf-8")
            except UnicodeEncodeError:
                return "a node name with a lone surrogate cannot be stored"
        return None


def non_finite(value: Any) -> bool:
    """Whether a float, or any element of a tuple of floats, is NaN or infinite."""
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, tuple):
        return not all(map(math.isfinite, value))
    return False
