"""The rules of the graph view: which entries of the CRDT document a replica shows.

Any peer with write access can put anything into the document's root maps. The
document itself is never refused (refusing part of a CRDT would break
convergence); instead every replica applies these rules, which depend only on
the entry and the ontology, so every replica shows the same graph from the
same document:

* a node key is a node id written in canonical decimal, ``0 < id < 2**53``;
  its value is a map whose ``@type`` is a node type of the ontology and whose
  ``@name`` is a valid name (:meth:`wm.limits.Limits.name_problem`);
* an edge key is ``"src>dst>type"`` with two valid ids and an edge type of the
  ontology, and its value is ``true``;
* an attribute (of a node, an edge, or a volatile register) is shown only if
  the ontology allows it on that type and its stored value has the declared
  type, is finite unless the entry allows otherwise, and is within the limits.

What does not fit is *left out*: absent from the index, reads, events and
dumps, and reported as a :class:`LeftOut` with the replica that sent it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from math import isfinite
from typing import Any

from .limits import FLOAT_BYTES, non_finite
from .ontology import MAX_EXACT_INT, U64_RANGE, AttributeSpec, ElementType, Ontology

MAX_NODE_ID = 2**53


@dataclass(frozen=True)
class LeftOut:
    """One entry of the document that the view leaves out, and who sent it."""

    kind: str  # "node", "edge", "node_attr", "edge_attr" or "volatile"
    key: str  # node key, edge key, or "<owner>.<attribute>"
    reason: str
    writer: str  # the replica whose message brought it ("disk", "snapshot" when read back from disk)

    def __str__(self) -> str:
        return f"{self.kind} {self.key!r}: {self.reason} (from {self.writer})"


def node_id_of(key: Any) -> int | None:
    """The node id a document key stands for, or None if it is not one."""
    if type(key) is not str or not key.isdecimal() or not key.isascii() or (key[0] == "0"):
        return None
    node_id = int(key)
    return node_id if node_id < MAX_NODE_ID else None


class ViewRules:
    """The checks of one ontology, applied to document content (not to local API calls)."""

    def __init__(self, ontology: Ontology) -> None:
        self.ontology = ontology
        self.limits = ontology.limits
        specs = {*ontology.attributes.values()}
        specs |= {
            spec
            for t in (*ontology.node_types.values(), *ontology.edge_types.values())
            for spec in t.overrides.values()
        }
        self._fits = {spec: _fits(spec, ontology.limits.max_value_bytes) for spec in specs}

    def node_problem(self, node_type: Any, name: Any) -> str | None:
        """Why a node map with this ``@type`` and ``@name`` is left out, or None."""
        if type(node_type) is not str or node_type not in self.ontology.node_types:
            return f"unknown node type {node_type!r:.60}"
        return self.limits.name_problem(name)

    def plain_nodes(
        self, heads: dict[str, tuple[Any, Any] | None]
    ) -> tuple[list[tuple[int, tuple[str, str]]], list[str]]:
        """The node entries plainly shown, as (id, (type, name)), and the keys left to check one by one.

        A catch-up sorts thousands of node maps by their key and head (their
        ``@type`` and ``@name`` as stored, None if not a map): this settles the
        common case in one pass, without a call per node. It only ever admits
        what :func:`node_id_of` and :meth:`node_problem` admit; anything else,
        a name that is not ASCII included, is left to them.
        """
        node_types, longest = self.ontology.node_types, self.limits.max_name_length
        shown: list[tuple[int, tuple[str, str]]] = []
        others = []
        for key, head in heads.items():
            if (
                head is not None
                and type(key) is str
                and key.isdecimal()
                and key.isascii()
                and key[0] != "0"
                and type(head[0]) is str
                and head[0] in node_types
                and type(name := head[1]) is str
                and 0 < len(name) <= longest
                and name[0] != "@"
                and name.isascii()
                and (node_id := int(key)) < MAX_NODE_ID
            ):
                shown.append((node_id, head))
            else:
                others.append(key)
        return shown, others

    def edge_parts(self, key: Any) -> tuple[int, int, str] | None:
        """(src, dst, type) of a valid edge key, or None."""
        if type(key) is not str:
            return None
        parts = key.split(">", 2)
        if len(parts) != 3:
            return None
        src, dst = node_id_of(parts[0]), node_id_of(parts[1])
        if src is None or dst is None or parts[2] not in self.ontology.edge_types:
            return None
        return src, dst, parts[2]

    def attr_fits(self, element: ElementType, attr: str, stored: Any) -> bool:
        """Whether the view shows a stored attribute of a node or edge of type ``element`` (the fast check of reads)."""
        return attr in element.attributes and self._fits[self.ontology.attribute_for(element, attr)](stored)

    def attr_problem(self, element: ElementType, attr: Any, stored: Any) -> str | None:
        """Why a stored attribute of a node or edge of type ``element`` is left out, or None."""
        if attr not in element.attributes:
            return f"attribute {attr!r:.60} is not allowed on {element.kind} type {element.name!r}"
        return self.value_problem(self.ontology.attribute_for(element, attr), stored)

    def value_problem(self, spec: AttributeSpec, stored: Any) -> str | None:
        """Why a value as stored (in the document or a volatile record) does not fit ``spec``, or None."""
        if self._fits[spec](stored):
            return None
        return self._explain(spec, stored) or f"{spec.name}: does not fit {spec.describe()}"

    def _explain(self, spec: AttributeSpec, stored: Any) -> str | None:
        if not _STORED_CHECKS[spec.type](stored):
            return f"{spec.name}: expected {spec.describe()}, got {type(stored).__name__}"
        if spec.type == "vec":
            if spec.length is not None and len(stored) != spec.length:
                return f"{spec.name}: expected {spec.describe()}, got a vector of length {len(stored)}"
            stored = tuple(stored)
        if not spec.nonfinite and non_finite(stored):
            return f"{spec.name}: NaN or infinity"
        return self.limits.size_problem(bytes(stored) if isinstance(stored, bytearray) else stored)

    def volatile_problem(self, owner: str, attr: Any, value: Any) -> str | None:
        """Why a remote volatile register is refused, or None (a None value deletes and always fits)."""
        kind, _, ident = owner.partition(":")
        if (node_id_of(ident) if kind == "n" else self.edge_parts(ident)) is None:
            return f"owner {owner!r:.60} is not a node id or an edge key"
        spec = self.ontology.attributes.get(attr) if type(attr) is str else None
        if spec is None or not spec.volatile:
            return f"{attr!r:.60} is not a volatile attribute"
        return None if value is None else self.value_problem(spec, value)


def _is_number(value: Any) -> bool:
    return type(value) is float or type(value) is int


def _is_int(value: Any) -> bool:
    return (type(value) is int or (type(value) is float and value.is_integer())) and abs(value) <= MAX_EXACT_INT


def _is_u64(value: Any) -> bool:
    """A uint64 as the ontology stores it: canonical decimal digits, below 2**64."""
    return (
        type(value) is str
        and value.isdecimal()
        and value.isascii()
        and len(value) <= 20
        and (value == "0" or value[0] != "0")
        and int(value) < U64_RANGE
    )


def _is_vec(value: Any) -> bool:
    return type(value) in (list, tuple) and all(map(_is_number, value))


def _fits(spec: AttributeSpec, max_bytes: int) -> Callable[[Any], bool]:
    """One attribute's whole rule (type, length, finite, size) as a single fast predicate on stored values.

    Stored strings are valid UTF-8 (pycrdt and msgpack refuse anything else),
    so a lone surrogate never needs looking for here.
    """
    finite = not spec.nonfinite
    if spec.type == "float":
        return (lambda v: type(v) is int or (type(v) is float and isfinite(v))) if finite else _is_number
    if spec.type == "str":
        return lambda v: type(v) is str and (len(v) * 4 <= max_bytes or len(v.encode("utf-8")) <= max_bytes)
    if spec.type == "bytes":
        return lambda v: type(v) in (bytes, bytearray) and len(v) <= max_bytes
    if spec.type == "vec":
        length, elements = spec.length, max_bytes // FLOAT_BYTES

        def fits_vec(v: Any) -> bool:
            return (
                type(v) in (list, tuple)
                and (len(v) == length if length is not None else len(v) <= elements)
                and all(type(x) is int or (type(x) is float and (not finite or isfinite(x))) for x in v)
            )

        return fits_vec
    return _STORED_CHECKS[spec.type]


_STORED_CHECKS: dict[str, Callable[[Any], bool]] = {
    "bool": lambda v: type(v) is bool,
    "int": _is_int,
    "float": _is_number,
    "str": lambda v: type(v) is str,
    "bytes": lambda v: type(v) in (bytes, bytearray),
    "vec": _is_vec,
    "u64": _is_u64,
    "u64vec": lambda v: type(v) in (list, tuple) and all(map(_is_u64, v)),
}
