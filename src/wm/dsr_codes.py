"""DSR's attribute value types: their names, their JSON type codes, and our value types.

DSR (robocomp/cortex) writes every attribute of a scene file as
``{"type": CODE, "value": ...}``. The codes are the index of the value in its
C++ variant: 0 string, 1 int32, 2 float, 3 float vector, 4 bool, 5 byte vector,
6 uint32, 7 uint64, 8 double, 9 uint64 vector, 10..13 fixed float arrays of
2, 3, 4 and 6. DSR writes a uint64 (and each item of a uint64 vector) as a
decimal string and a uint32 as its int32 bit pattern; :func:`from_json` and
:func:`to_json` undo and redo exactly that, so values round-trip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .errors import SceneFormatError

UINT32_RANGE = 2**32
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


@dataclass(frozen=True)
class DsrType:
    """One DSR value type: its JSON code and how we hold it (value type, fixed vector length)."""

    name: str
    code: int
    ours: str
    length: int | None = None


DSR_TYPES: dict[str, DsrType] = {
    t.name: t
    for t in (
        DsrType("string", 0, "str"),
        DsrType("int", 1, "int"),
        DsrType("float", 2, "float"),
        DsrType("float vector", 3, "vec"),
        DsrType("bool", 4, "bool"),
        DsrType("byte vector", 5, "bytes"),
        DsrType("uint32", 6, "int"),
        DsrType("uint64", 7, "u64"),
        DsrType("double", 8, "float"),
        DsrType("uint64 vector", 9, "u64vec"),
        DsrType("float[2]", 10, "vec", 2),
        DsrType("float[3]", 11, "vec", 3),
        DsrType("float[4]", 12, "vec", 4),
        DsrType("float[6]", 13, "vec", 6),
    )
}
BY_CODE: dict[int, DsrType] = {t.code: t for t in DSR_TYPES.values()}
_DEFAULT_FOR_OURS = {
    "str": "string",
    "float": "float",
    "vec": "float vector",
    "bool": "bool",
    "bytes": "byte vector",
    "u64": "uint64",
    "u64vec": "uint64 vector",
}


def _number(value: Any) -> float:
    """DSR's reader accepts a float written as a string, with a decimal comma too."""
    if isinstance(value, str):
        return float(value.replace(",", "."))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"not a number: {value!r:.40}")
    return float(value)


def _integer(value: Any) -> int:
    if isinstance(value, str):
        return int(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value):
        raise TypeError(f"not an integer: {value!r:.40}")
    return int(value)


def _items(value: Any) -> list[Any]:
    if not isinstance(value, list):
        raise TypeError(f"not a list: {value!r:.40}")
    return value


def from_json(code: Any, value: Any, where: str) -> Any:
    """The Python value of one ``{"type": code, "value": value}`` entry of a DSR file."""
    kind = BY_CODE.get(code) if isinstance(code, int) and not isinstance(code, bool) else None
    if kind is None:
        raise SceneFormatError(f"{where}: unknown DSR attribute type code {code!r} (expected 0..13)")
    try:
        if kind.ours == "str":
            return value if isinstance(value, str) else str(value)
        if kind.ours == "bool":
            if not isinstance(value, bool):
                raise TypeError(f"not a bool: {value!r:.40}")
            return value
        if kind.ours == "float":
            return _number(value)
        if kind.name == "uint32":
            return _integer(value) % UINT32_RANGE  # DSR writes a uint32 as its int32 bit pattern
        if kind.ours in ("int", "u64"):
            return _integer(value)
        if kind.ours == "bytes":
            return bytes(_integer(v) for v in _items(value))
        if kind.ours == "u64vec":
            return [_integer(v) for v in _items(value)]
        return [_number(v) for v in _items(value)]
    except (TypeError, ValueError) as exc:
        raise SceneFormatError(
            f"{where}: a DSR {kind.name} (type {kind.code}) cannot hold {value!r:.60}: {exc}"
        ) from None


def dsr_type_of(ours: str, length: int | None, dsr_name: str | None, value: Any) -> DsrType:
    """The DSR type to write a value as: the declared one, or the closest to our value type."""
    if dsr_name is not None:
        return DSR_TYPES[dsr_name]
    if ours == "int":
        if INT32_MIN <= value <= INT32_MAX:
            return DSR_TYPES["int"]
        return DSR_TYPES["uint64"] if value >= 0 else DSR_TYPES["double"]
    if ours == "vec" and length in (2, 3, 4, 6):
        return DSR_TYPES["float vector"]  # DSR reads fixed arrays on edges only; a plain vector loads everywhere
    return DSR_TYPES[_DEFAULT_FOR_OURS[ours]]


def to_json(kind: DsrType, value: Any) -> dict[str, Any]:
    """One attribute as DSR writes it: ``{"type": code, "value": ...}``."""
    if kind.ours == "u64":
        written: Any = str(value)
    elif kind.ours == "u64vec":
        written = [str(v) for v in value]
    elif kind.name == "uint32":
        written = value - UINT32_RANGE if value > INT32_MAX else value
    elif kind.ours == "bytes":
        written = list(value)
    elif kind.ours == "vec":
        written = list(value)
    else:
        written = value
    return {"type": kind.code, "value": written}
