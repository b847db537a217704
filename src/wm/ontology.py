"""The ontology: which node types, edge types and attributes exist, as data.

An ontology is a YAML (or JSON) file loaded at run time. It declares every
attribute once, with its value type and whether it is *volatile* (high-rate,
last-writer-wins, see :mod:`wm.volatile`), and lists which attributes each node
type and edge type may carry. Every write is checked against it; see
``docs/ontology.md`` for the file format.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import AttributeTypeError, OntologyError, UnknownAttributeError, UnknownTypeError
from .limits import Limits, non_finite

VALUE_TYPES = ("bool", "int", "float", "str", "vec", "bytes")
_REAL = frozenset({"float", "vec"})  # may hold NaN or infinity
_SIZED = frozenset({"str", "bytes", "vec"})  # capped by Limits.max_value_bytes
MAX_EXACT_INT = 2**53  # values travel as float64 inside the CRDT
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

Value = bool | int | float | str | bytes | tuple[float, ...]


@dataclass(frozen=True)
class AttributeSpec:
    """One declared attribute: its value type, optional vector length and volatility."""

    name: str
    type: str
    length: int | None = None
    volatile: bool = False
    doc: str = ""
    nonfinite: bool = False  # whether NaN and ±inf are allowed (float and vec)

    def coerce(self, value: Any, owner: str) -> Value:
        """Return ``value`` in canonical form, or raise :class:`AttributeTypeError`."""
        checker = _COERCERS[self.type]
        try:
            result = checker(value)
        except (TypeError, ValueError) as exc:
            raise AttributeTypeError(
                f"{owner}.{self.name}: expected {self.describe()}, got {type(value).__name__} {value!r:.60}"
            ) from exc
        if self.length is not None and len(result) != self.length:  # type: ignore[arg-type]
            raise AttributeTypeError(
                f"{owner}.{self.name}: expected {self.describe()}, got a vector of length {len(result)}"  # type: ignore[arg-type]
            )
        if self.type in _REAL and not self.nonfinite and non_finite(result):
            raise AttributeTypeError(f"{owner}.{self.name}: NaN and infinity are not allowed (the ontology entry says so)")
        return result

    def decode(self, stored: Any) -> Value:
        """Turn a value read back from the CRDT into its canonical Python type."""
        if self.type == "int":
            return int(stored)
        if self.type == "vec":
            return tuple(float(x) for x in stored)
        if self.type == "bytes":
            return bytes(stored)
        return stored

    def describe(self) -> str:
        if self.type == "vec" and self.length is not None:
            return f"vec[{self.length}]"
        return self.type


def _as_bool(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError("not a bool")


def _as_int(value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError("not an int")
    if abs(int(value)) > MAX_EXACT_INT:
        raise ValueError("int out of the exact range ±2**53")
    return int(value)


def _as_float(value: Any) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError("not a number")
    return float(value)


def _as_str(value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError("not a str")
    return value


def _as_bytes(value: Any) -> bytes:
    if not isinstance(value, (bytes, bytearray, memoryview)):
        raise TypeError("not bytes")
    return bytes(value)


def _as_vec(value: Any) -> tuple[float, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError("not a sequence")
    array = np.asarray(value)
    if array.ndim != 1 or not (np.issubdtype(array.dtype, np.number)) or np.issubdtype(array.dtype, np.bool_):
        raise TypeError("not a 1-D numeric sequence")
    return tuple(float(x) for x in array)


_COERCERS = {
    "bool": _as_bool,
    "int": _as_int,
    "float": _as_float,
    "str": _as_str,
    "bytes": _as_bytes,
    "vec": _as_vec,
}


@dataclass(frozen=True)
class ElementType:
    """A node type or an edge type, with the attributes it may carry."""

    kind: str  # "node" or "edge"
    name: str
    attributes: frozenset[str]
    doc: str = ""


class Ontology:
    """A validated ontology. Build one with :meth:`load`, :meth:`from_dict` or :meth:`default`."""

    def __init__(
        self,
        attributes: Mapping[str, AttributeSpec],
        node_types: Mapping[str, ElementType],
        edge_types: Mapping[str, ElementType],
        source: str = "<dict>",
        limits: Limits = Limits(),
    ) -> None:
        self.attributes = dict(attributes)
        self.node_types = dict(node_types)
        self.edge_types = dict(edge_types)
        self.source = source
        self.limits = limits

    # -- loading ---------------------------------------------------------------

    @classmethod
    def default(cls) -> Ontology:
        """The ontology shipped with the package (the caregiving scenario and DSR basics)."""
        text = resources.files("wm").joinpath("default_ontology.yaml").read_text(encoding="utf-8")
        return cls.from_text(text, source="wm/default_ontology.yaml")

    @classmethod
    def load(cls, path: str | Path) -> Ontology:
        """Load and validate an ontology file (YAML or JSON)."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise OntologyError(f"{path}: cannot read the ontology file: {exc.strerror}") from exc
        return cls.from_text(text, source=str(path))

    @classmethod
    def from_text(cls, text: str, source: str = "<text>") -> Ontology:
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise OntologyError(f"{source}: not valid YAML/JSON: {exc}") from exc
        return cls.from_dict(data, source=source)

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Ontology:
        """Validate a parsed ontology document; errors name the offending key."""
        if not isinstance(data, Mapping):
            raise OntologyError(f"{source}: the ontology must be a mapping with 'attributes', 'nodes' and 'edges'")
        unknown = set(data) - {"version", "attributes", "nodes", "edges", "limits"}
        if unknown:
            raise OntologyError(f"{source}: unknown top-level key {sorted(unknown)[0]!r}")
        attributes = {
            name: _parse_attribute(name, spec, f"{source}: attributes.{name}")
            for name, spec in _mapping(data.get("attributes", {}), f"{source}: attributes").items()
        }
        node_types = _parse_types("node", data.get("nodes", {}), attributes, f"{source}: nodes")
        edge_types = _parse_types("edge", data.get("edges", {}), attributes, f"{source}: edges")
        return cls(attributes, node_types, edge_types, source, _parse_limits(data.get("limits"), f"{source}: limits"))

    # -- checking writes -------------------------------------------------------

    def node_type(self, name: str) -> ElementType:
        try:
            return self.node_types[name]
        except (KeyError, TypeError):
            raise UnknownTypeError(f"unknown node type {name!r} (ontology {self.source})") from None

    def edge_type(self, name: str) -> ElementType:
        try:
            return self.edge_types[name]
        except (KeyError, TypeError):
            raise UnknownTypeError(f"unknown edge type {name!r} (ontology {self.source})") from None

    def check_attrs(self, element: ElementType, attrs: Mapping[str, Any] | None) -> dict[str, Value]:
        """Validate and coerce a set of attribute writes for one node or edge type."""
        if not attrs:
            return {}
        if not isinstance(attrs, Mapping):
            raise AttributeTypeError(f"{element.name}: attributes must be a mapping, got {type(attrs).__name__}")
        return {name: self._checked(self.attribute_for(element, name), value, element.name) for name, value in attrs.items()}

    def _checked(self, spec: AttributeSpec, value: Any, owner: str) -> Value:
        result = spec.coerce(value, owner)
        if spec.type in _SIZED and (problem := self.limits.size_problem(result)) is not None:
            raise AttributeTypeError(f"{owner}.{spec.name}: {problem}")
        return result

    def attribute_for(self, element: ElementType, name: str) -> AttributeSpec:
        """The spec of ``name`` on this type, or :class:`UnknownAttributeError`."""
        if name not in element.attributes:
            raise UnknownAttributeError(
                f"attribute {name!r} is not allowed on {element.kind} type {element.name!r} (ontology {self.source})"
            )
        return self.attributes[name]

    def is_volatile(self, name: str) -> bool:
        spec = self.attributes.get(name)
        return spec is not None and spec.volatile

    def decode(self, name: str, stored: Any) -> Any:
        """Decode a stored value; attributes unknown to this ontology pass through unchanged."""
        spec = self.attributes.get(name)
        return stored if spec is None else spec.decode(stored)


def _mapping(value: Any, where: str) -> Mapping[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise OntologyError(f"{where}: expected a mapping, got {type(value).__name__}")
    for key in value:
        if not isinstance(key, str) or not _IDENTIFIER.match(key):
            raise OntologyError(f"{where}.{key}: names must be identifiers (letters, digits, '_')")
    return value


def _parse_attribute(name: str, spec: Any, where: str) -> AttributeSpec:
    if isinstance(spec, str):
        spec = {"type": spec}
    if not isinstance(spec, Mapping):
        raise OntologyError(f"{where}: expected a mapping or a type name, got {type(spec).__name__}")
    unknown = set(spec) - {"type", "length", "volatile", "doc", "nonfinite"}
    if unknown:
        raise OntologyError(f"{where}.{sorted(unknown)[0]}: unknown key")
    value_type = spec.get("type")
    if value_type not in VALUE_TYPES:
        raise OntologyError(f"{where}.type: expected one of {', '.join(VALUE_TYPES)}, got {value_type!r}")
    length = spec.get("length")
    if length is not None and (value_type != "vec" or not isinstance(length, int) or isinstance(length, bool) or length < 1):
        raise OntologyError(f"{where}.length: only a vec may have a length, and it must be a positive int")
    volatile = spec.get("volatile", False)
    if not isinstance(volatile, bool):
        raise OntologyError(f"{where}.volatile: expected true or false, got {volatile!r}")
    nonfinite = spec.get("nonfinite", False)
    if not isinstance(nonfinite, bool) or (nonfinite and value_type not in ("float", "vec")):
        raise OntologyError(f"{where}.nonfinite: only a float or a vec may allow NaN and infinity (true or false)")
    return AttributeSpec(name, value_type, length, volatile, str(spec.get("doc", "")), nonfinite)


def _parse_limits(section: Any, where: str) -> Limits:
    defaults = Limits()
    values = {}
    for key, value in _mapping(section, where).items():
        if not hasattr(defaults, key):
            raise OntologyError(f"{where}.{key}: unknown limit")
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise OntologyError(f"{where}.{key}: expected a positive int, got {value!r}")
        values[key] = value
    try:
        return Limits(**values)
    except ValueError as exc:
        raise OntologyError(f"{where}: {exc}") from None


def _parse_types(kind: str, section: Any, attributes: Mapping[str, AttributeSpec], where: str) -> dict[str, ElementType]:
    types: dict[str, ElementType] = {}
    for type_name, spec in _mapping(section, where).items():
        spec = spec or {}
        if not isinstance(spec, Mapping):
            raise OntologyError(f"{where}.{type_name}: expected a mapping, got {type(spec).__name__}")
        unknown = set(spec) - {"attributes", "doc"}
        if unknown:
            raise OntologyError(f"{where}.{type_name}.{sorted(unknown)[0]}: unknown key")
        listed = spec.get("attributes", []) or []
        if not isinstance(listed, list):
            raise OntologyError(f"{where}.{type_name}.attributes: expected a list of attribute names")
        for index, attr in enumerate(listed):
            if attr not in attributes:
                raise OntologyError(f"{where}.{type_name}.attributes[{index}]: undeclared attribute {attr!r}")
        types[type_name] = ElementType(kind, type_name, frozenset(listed), str(spec.get("doc", "")))
    return types
