"""The ontology: which node types, edge types and attributes exist, as data.

An ontology is a YAML (or JSON) file loaded at run time. It declares every
attribute once, with its value type and whether it is *volatile* (high-rate,
last-writer-wins, see :mod:`wm.volatile`), and lists which attributes each node
type and edge type may carry. Every write is checked against it; see
``docs/ontology.md`` for the file format.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import yaml

from . import plugins
from .dsr_codes import DSR_TYPES
from .errors import AttributeTypeError, OntologyError, PluginError, UnknownAttributeError, UnknownTypeError, WMError
from .limits import Limits, non_finite

VALUE_TYPES = ("bool", "int", "float", "str", "vec", "bytes", "u64", "u64vec")
_REAL = frozenset({"float", "vec"})  # may hold NaN or infinity
_SIZED = frozenset({"str", "bytes", "vec", "u64vec"})  # capped by Limits.max_value_bytes
MAX_EXACT_INT = 2**53  # values travel as float64 inside the CRDT
U64_RANGE = 2**64  # u64 values travel as decimal strings, so that every uint64 is exact
BASE = "base"
DEFAULT = "default"
PACKAGED = {BASE: "base_ontology.yaml", "dsr": "dsr_ontology.yaml"}  # wm's own; plugins add more (wm.plugins)
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

Value = bool | int | float | str | bytes | tuple[float, ...] | tuple[str, ...]  # u64vec is stored as decimal strings


@dataclass(frozen=True)
class AttributeSpec:
    """One declared attribute: its value type, optional vector length, volatility and DSR type."""

    name: str
    type: str
    length: int | None = None
    volatile: bool = False
    doc: str = ""
    dsr: str | None = None  # the DSR value type name (wm.dsr_codes) it is written as in DSR files
    nonfinite: bool = False  # whether NaN and ±inf are allowed (float and vec)

    def coerce(self, value: Any, owner: str) -> Value:
        """Return ``value`` in the form it is stored in, or raise :class:`AttributeTypeError`.

        That is the canonical Python value, except that a ``u64`` is stored as a
        decimal string (and a ``u64vec`` as a tuple of them).
        """
        checker = _COERCERS[self.type]
        try:
            result = checker(value)
        except (TypeError, ValueError) as exc:
            raise AttributeTypeError(
                f"{owner}.{self.name}: expected {self.describe()}, got {type(value).__name__} {value!r:.60}"
            ) from exc
        if self.length is not None and isinstance(result, tuple) and len(result) != self.length:
            raise AttributeTypeError(
                f"{owner}.{self.name}: expected {self.describe()}, got a vector of length {len(result)}"
            )
        if self.type in _REAL and not self.nonfinite and non_finite(result):
            raise AttributeTypeError(
                f"{owner}.{self.name}: NaN and infinity are not allowed (the ontology entry says so)"
            )
        return result

    def decode(self, stored: Any) -> Value:
        """Turn a value read back from the CRDT into its canonical Python type."""
        if self.type == "int":
            return int(stored)
        if self.type == "vec":
            return tuple(float(x) for x in stored)
        if self.type == "bytes":
            return bytes(stored)
        if self.type == "u64":
            return int(stored)
        if self.type == "u64vec":
            return tuple(int(x) for x in stored)
        value: Value = stored
        return value

    def describe(self) -> str:
        if self.type == "vec" and self.length is not None:
            return f"vec[{self.length}]"
        return self.type

    def holds(self, stored: Any) -> bool:
        """Whether a stored value has this attribute's storage form (to tell clashing declarations apart)."""
        storage = _STORAGE[self.type]
        if not isinstance(stored, storage) or (self.type in ("int", "float") and isinstance(stored, bool)):
            return False
        if isinstance(stored, (list, tuple)) and self.type in ("vec", "u64vec") and stored:
            return isinstance(stored[0], str) == (self.type == "u64vec")
        return True


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


def _as_u64(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError("not an int")
    if not 0 <= int(value) < U64_RANGE:
        raise ValueError("out of the uint64 range 0..2**64-1")
    return str(int(value))


def _as_u64vec(value: Any) -> tuple[str, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError("not a sequence")
    return tuple(_as_u64(x) for x in value)


def _as_vec(value: Any) -> tuple[float, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError("not a sequence")
    array = np.asarray(value)
    if array.ndim != 1 or not (np.issubdtype(array.dtype, np.number)) or np.issubdtype(array.dtype, np.bool_):
        raise TypeError("not a 1-D numeric sequence")
    return tuple(float(x) for x in array)


_STORAGE: dict[str, type | tuple[type, ...]] = {
    "bool": bool,
    "int": (int, float),
    "float": (int, float),
    "str": str,
    "u64": str,
    "bytes": (bytes, bytearray),
    "vec": (list, tuple),
    "u64vec": (list, tuple),
}
_COERCERS: dict[str, Callable[[Any], Value]] = {
    "bool": _as_bool,
    "int": _as_int,
    "float": _as_float,
    "str": _as_str,
    "bytes": _as_bytes,
    "vec": _as_vec,
    "u64": _as_u64,
    "u64vec": _as_u64vec,
}


@dataclass(frozen=True)
class ElementType:
    """A node type or an edge type, with the attributes it may carry."""

    kind: str  # "node" or "edge"
    name: str
    attributes: frozenset[str]
    doc: str = ""
    show: tuple[str, ...] = ()  # the attributes a summary (wm monitor's tables) shows first, in order
    # attributes whose declaration here differs from the ontology-wide one (an included ontology's, see include)
    overrides: Mapping[str, AttributeSpec] = field(default_factory=lambda: MappingProxyType({}))


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
        self._variants: dict[str, list[AttributeSpec]] = {}
        for element in (*self.node_types.values(), *self.edge_types.values()):
            for name, spec in element.overrides.items():
                variants = self._variants.setdefault(name, [self.attributes[name]])
                if spec not in variants:
                    variants.append(spec)
        self.limits = limits

    # -- loading ---------------------------------------------------------------

    @classmethod
    def default(cls) -> Ontology:
        """The default ontology: the one an installed application names ``default`` (a ``wm.ontologies``
        entry point, see :mod:`wm.plugins`), else the neutral ``base``."""
        return cls.named(DEFAULT)

    @classmethod
    def named(cls, name: str) -> Ontology:
        """A packaged ontology by name: ``base``, ``dsr``, ``default``, or one an installed plugin adds."""
        built = _packaged(name)
        return cls(
            built.attributes, built.node_types, built.edge_types, built.source, built.limits
        )  # own dicts, shared specs

    @staticmethod
    def names() -> list[str]:
        """The names :meth:`named` knows: wm's own ontologies, ``default``, and those of installed plugins."""
        return sorted({*PACKAGED, DEFAULT, *plugins.ontology_files()})

    @classmethod
    def load(cls, path: str | Path) -> Ontology:
        """Load and validate an ontology file (YAML or JSON), or a packaged one by name (see :meth:`named`)."""
        if isinstance(path, str) and _IDENTIFIER.match(path) and not Path(path).exists():
            return cls.named(path)
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
        unknown = set(data) - {"version", "include", "attributes", "nodes", "edges", "limits"}
        if unknown:
            raise OntologyError(f"{source}: unknown top-level key {sorted(unknown)[0]!r}")
        attributes = {
            name: _parse_attribute(name, spec, f"{source}: attributes.{name}")
            for name, spec in _mapping(data.get("attributes", {}), f"{source}: attributes").items()
        }
        included = [cls._include(ref, source) for ref in _include_list(data.get("include"), source)]
        known = {name: spec for base in included for name, spec in base.attributes.items()} | attributes
        node_types = _parse_types("node", data.get("nodes", {}), known, f"{source}: nodes")
        edge_types = _parse_types("edge", data.get("edges", {}), known, f"{source}: edges")
        limits = _parse_limits(data.get("limits"), f"{source}: limits")
        ontology = cls(attributes, node_types, edge_types, source, limits)
        for base in reversed(included):
            ontology = _merge(base, ontology)
        return ontology

    @classmethod
    def _include(cls, ref: str, source: str) -> Ontology:
        if _IDENTIFIER.match(ref) and ref in cls.names():
            return cls.named(ref)
        path = Path(ref) if Path(ref).is_absolute() or _IDENTIFIER.match(source) else Path(source).parent / ref
        return cls.load(path)

    def declares(self, kind: str, type_name: str) -> bool:
        return type_name in (self.node_types if kind == "node" else self.edge_types)

    @staticmethod
    def packaged_declaring(kind: str, type_name: str) -> list[str]:
        """The names of the packaged ontologies that declare this node or edge type (plugins' that load included), ``default`` first."""
        found = []
        for name in sorted(Ontology.names(), key=lambda name: name != DEFAULT):
            try:
                if Ontology.named(name).declares(kind, type_name):
                    found.append(name)
            except WMError:
                continue  # a broken plugin is reported where it is asked for by name
        return found

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
        return {
            name: self._checked(self.attribute_for(element, name), value, element.name) for name, value in attrs.items()
        }

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
        return element.overrides.get(name) or self.attributes[name]

    def is_volatile(self, name: str) -> bool:
        spec = self.attributes.get(name)
        return spec is not None and spec.volatile

    def decode(self, name: str, stored: Any) -> Any:
        """Decode a stored value; attributes unknown to this ontology pass through unchanged."""
        spec = self.attributes.get(name)
        if name in self._variants:  # declared differently on different types: the stored form tells which
            spec = next((v for v in self._variants[name] if v.holds(stored)), spec)
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


@functools.cache
def _packaged(name: str) -> Ontology:
    """A packaged ontology (wm's own or a plugin's), read and validated once per process."""
    if name in PACKAGED:
        return Ontology.from_text(
            resources.files("wm").joinpath(PACKAGED[name]).read_text(encoding="utf-8"), source=name
        )
    found = plugins.ontology_files().get(name)
    if found is None:
        if name == DEFAULT:
            return _packaged(BASE)
        raise OntologyError(f"no packaged ontology named {name!r}; known: {', '.join(Ontology.names())}")
    file = found()
    try:
        text = (
            file.read_text(encoding="utf-8") if hasattr(file, "read_text") else Path(file).read_text(encoding="utf-8")
        )
    except (OSError, TypeError) as exc:
        raise PluginError(f"plugin ontology {name!r} ({plugins.ONTOLOGIES}): cannot read {file!r}: {exc}") from exc
    return Ontology.from_text(text, source=name)


def _include_list(value: Any, source: str) -> list[str]:
    if value is None:
        return []
    if not isinstance(value, list) or not all(isinstance(ref, str) for ref in value):
        raise OntologyError(f"{source}: include: expected a list of packaged names or file paths")
    return value


def _merge(base: Ontology, top: Ontology) -> Ontology:
    """``top`` over an included ``base``: types are united, ``top``'s declarations win.

    An attribute that ``top`` declares with another value type than ``base``
    keeps ``base``'s declaration wherever only ``base`` lists it on a type.
    """
    attributes = dict(base.attributes)
    clashes: dict[str, AttributeSpec] = {}
    for name, spec in top.attributes.items():
        below = base.attributes.get(name)
        if below is not None and below.type != spec.type:
            if below.volatile != spec.volatile:
                raise OntologyError(
                    f"{top.source}: attributes.{name}: redeclares {base.source}'s attribute with another volatility"
                )
            clashes[name] = below
            attributes[name] = spec
        else:
            attributes[name] = replace(spec, dsr=spec.dsr or (below.dsr if below else None))

    def united(mine: Mapping[str, ElementType], theirs: Mapping[str, ElementType]) -> dict[str, ElementType]:
        types: dict[str, ElementType] = {}
        for name, lower in theirs.items():
            upper = mine.get(name)
            own = upper.attributes if upper is not None else frozenset()
            overrides = {
                **lower.overrides,
                **{a: clashes[a] for a in lower.attributes - own if a in clashes},
                **(upper.overrides if upper is not None else {}),
            }
            types[name] = replace(lower, overrides=MappingProxyType(overrides))
            if upper is not None:
                types[name] = replace(
                    types[name],
                    attributes=own | lower.attributes,
                    doc=upper.doc or lower.doc,
                    show=upper.show or lower.show,
                )
        for name, upper in mine.items():
            types.setdefault(name, upper)
        return types

    return Ontology(
        attributes,
        united(top.node_types, base.node_types),
        united(top.edge_types, base.edge_types),
        top.source,
        top.limits,
    )


def _parse_attribute(name: str, spec: Any, where: str) -> AttributeSpec:
    if isinstance(spec, str):
        spec = {"type": spec}
    if not isinstance(spec, Mapping):
        raise OntologyError(f"{where}: expected a mapping or a type name, got {type(spec).__name__}")
    unknown = set(spec) - {"type", "length", "volatile", "doc", "dsr", "nonfinite"}
    if unknown:
        raise OntologyError(f"{where}.{sorted(unknown)[0]}: unknown key")
    value_type = spec.get("type")
    if value_type not in VALUE_TYPES:
        raise OntologyError(f"{where}.type: expected one of {', '.join(VALUE_TYPES)}, got {value_type!r}")
    length = spec.get("length")
    if length is not None and (
        value_type != "vec" or not isinstance(length, int) or isinstance(length, bool) or length < 1
    ):
        raise OntologyError(f"{where}.length: only a vec may have a length, and it must be a positive int")
    volatile = spec.get("volatile", False)
    if not isinstance(volatile, bool):
        raise OntologyError(f"{where}.volatile: expected true or false, got {volatile!r}")
    dsr = spec.get("dsr")
    if dsr is not None:
        dsr_type = DSR_TYPES.get(dsr)
        if dsr_type is None:
            raise OntologyError(f"{where}.dsr: expected one of {', '.join(DSR_TYPES)}, got {dsr!r}")
        if dsr_type.ours != value_type or (dsr_type.length is not None and dsr_type.length != length):
            raise OntologyError(
                f"{where}.dsr: a DSR {dsr} is not held by {value_type}" + (f"[{length}]" if length else "")
            )
    nonfinite = spec.get("nonfinite", False)
    if not isinstance(nonfinite, bool) or (nonfinite and value_type not in ("float", "vec")):
        raise OntologyError(f"{where}.nonfinite: only a float or a vec may allow NaN and infinity (true or false)")
    return AttributeSpec(name, value_type, length, volatile, str(spec.get("doc", "")), dsr, nonfinite)


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


def _parse_types(
    kind: str, section: Any, attributes: Mapping[str, AttributeSpec], where: str
) -> dict[str, ElementType]:
    types: dict[str, ElementType] = {}
    for type_name, spec in _mapping(section, where).items():
        spec = spec or {}
        if not isinstance(spec, Mapping):
            raise OntologyError(f"{where}.{type_name}: expected a mapping, got {type(spec).__name__}")
        unknown = set(spec) - {"attributes", "doc", "show"}
        if unknown:
            raise OntologyError(f"{where}.{type_name}.{sorted(unknown)[0]}: unknown key")
        listed = spec.get("attributes", []) or []
        if not isinstance(listed, list):
            raise OntologyError(f"{where}.{type_name}.attributes: expected a list of attribute names")
        for index, attr in enumerate(listed):
            if attr not in attributes:
                raise OntologyError(f"{where}.{type_name}.attributes[{index}]: undeclared attribute {attr!r}")
        show = spec.get("show", []) or []
        if not isinstance(show, list):
            raise OntologyError(f"{where}.{type_name}.show: expected a list of attribute names")
        for index, attr in enumerate(show):
            if attr not in attributes:
                raise OntologyError(f"{where}.{type_name}.show[{index}]: undeclared attribute {attr!r}")
        types[type_name] = ElementType(kind, type_name, frozenset(listed), str(spec.get("doc", "")), tuple(show))
    return types
