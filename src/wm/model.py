"""Immutable snapshots of nodes and edges, as handed to callers of :class:`wm.Graph`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any


def freeze(attrs: dict[str, Any]) -> Mapping[str, Any]:
    return MappingProxyType(attrs)


@dataclass(frozen=True)
class Node:
    """A node as it was when it was read: id, type, unique name and attributes."""

    id: int
    type: str
    name: str
    attrs: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    def get(self, attr: str, default: Any = None) -> Any:
        return self.attrs.get(attr, default)


@dataclass(frozen=True)
class Edge:
    """An edge as it was when it was read, keyed by (src, dst, type)."""

    src: int
    dst: int
    type: str
    attrs: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def key(self) -> tuple[int, int, str]:
        return (self.src, self.dst, self.type)

    def get(self, attr: str, default: Any = None) -> Any:
        return self.attrs.get(attr, default)


def edge_key(src: int, dst: int, edge_type: str) -> str:
    """The string key of an edge inside the CRDT document."""
    return f"{src}>{dst}>{edge_type}"


def parse_edge_key(key: str) -> tuple[int, int, str]:
    src, dst, edge_type = key.split(">", 2)
    return int(src), int(dst), edge_type
