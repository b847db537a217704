"""Typed reading of nested plain data (YAML documents, msgpack dicts) with key-path errors.

A :class:`Fields` wraps one mapping and knows where it sits in the document, so
every complaint names the exact key path, e.g.
``people[0].speed: expected a positive number, got 'fast'``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import Any

_MISSING: Any = object()


class Fields:
    """Read typed values out of one mapping, raising ``error`` with the key path on misuse."""

    def __init__(self, data: object, path: str, error: type[ValueError]) -> None:
        if not isinstance(data, Mapping):
            raise error(f"{path or '<root>'}: expected a mapping, got {_show(data)}")
        self._data = data
        self._path = path
        self._error = error

    def path_of(self, key: str) -> str:
        """The full key path of ``key`` inside this mapping."""
        return f"{self._path}.{key}" if self._path else key

    def fail(self, key: str, message: str) -> ValueError:
        """Build the error for ``key`` (the caller raises it)."""
        return self._error(f"{self.path_of(key)}: {message}")

    def _get(self, key: str, default: Any) -> Any:
        if key in self._data:
            return self._data[key]
        if default is _MISSING:
            raise self.fail(key, "is required")
        return default

    def number(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        positive: bool = False,
        non_negative: bool = False,
        at_most: float | None = None,
    ) -> float:
        """A finite real number, optionally constrained."""
        value = self._get(key, default)
        return self.check_number(key, value, positive=positive, non_negative=non_negative, at_most=at_most)

    def check_number(
        self, key: str, value: Any, *, positive: bool = False, non_negative: bool = False, at_most: float | None = None
    ) -> float:
        """Validate an already-extracted value as a number (used for list items)."""
        kind = "a positive number" if positive else "a non-negative number" if non_negative else "a number"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(key, f"expected {kind}, got {_show(value)}")
        if (positive and value <= 0) or (non_negative and value < 0):
            raise self.fail(key, f"expected {kind}, got {_show(value)}")
        if at_most is not None and value > at_most:
            raise self.fail(key, f"expected at most {at_most}, got {_show(value)}")
        return float(value)

    def string(self, key: str, default: Any = _MISSING, *, choices: frozenset[str] | None = None) -> str:
        """A non-empty string, optionally from a fixed set."""
        value = self._get(key, default)
        if not isinstance(value, str) or not value:
            raise self.fail(key, f"expected a non-empty string, got {_show(value)}")
        if choices is not None and value not in choices:
            raise self.fail(key, f"expected one of {sorted(choices)}, got {_show(value)}")
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        """A true/false value."""
        value = self._get(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {_show(value)}")
        return value

    def numbers(self, key: str, count: int | None = None, default: Any = _MISSING) -> tuple[float, ...]:
        """A list of exactly ``count`` numbers (of any length when ``count`` is None)."""
        value = self._get(key, default)
        if not isinstance(value, (list, tuple)) or count is not None and len(value) != count:
            raise self.fail(
                key, f"expected a list of {'' if count is None else f'{count} '}numbers, got {_show(value)}"
            )
        return tuple(self.check_number(f"{key}[{i}]", v) for i, v in enumerate(value))

    def has(self, key: str) -> bool:
        """Whether ``key`` is present and not null."""
        return self._data.get(key) is not None

    def keys(self) -> list[str]:
        """The mapping's keys, each checked to be a string."""
        for key in self._data:
            if not isinstance(key, str):
                raise self._error(f"{self._path or '<root>'}: expected string keys, got {_show(key)}")
        return list(self._data)

    def optional_number(self, key: str) -> float | None:
        """A number, or ``None`` when absent or null."""
        value = self._data.get(key)
        return None if value is None else self.check_number(key, value)

    def pairs(self, key: str) -> tuple[tuple[float, float], ...]:
        """A list of ``[x, y]`` points."""
        value = self._get(key, _MISSING)
        if not isinstance(value, (list, tuple)):
            raise self.fail(key, f"expected a list of [x, y] points, got {_show(value)}")
        out = []
        for i, item in enumerate(value):
            if not isinstance(item, (list, tuple)) or len(item) != 2:
                raise self.fail(f"{key}[{i}]", f"expected an [x, y] point, got {_show(item)}")
            out.append((self.check_number(f"{key}[{i}][0]", item[0]), self.check_number(f"{key}[{i}][1]", item[1])))
        return tuple(out)

    def child(self, key: str, default: Any = _MISSING) -> Fields:
        """The nested mapping at ``key``."""
        return Fields(self._get(key, default), self.path_of(key), self._error)

    def optional_child(self, key: str) -> Fields | None:
        """The nested mapping at ``key``, or ``None`` when absent or null."""
        value = self._data.get(key)
        return None if value is None else Fields(value, self.path_of(key), self._error)

    def children(self, key: str, default: Any = _MISSING) -> Iterator[Fields]:
        """Each mapping of the list at ``key``."""
        for i, item in enumerate(self._list(key, default)):
            yield Fields(item, f"{self.path_of(key)}[{i}]", self._error)

    def children_or_null(self, key: str) -> Iterator[Fields | None]:
        """Each entry of the list at ``key``: a mapping, or ``None`` for a null entry."""
        for i, item in enumerate(self._list(key, _MISSING)):
            yield None if item is None else Fields(item, f"{self.path_of(key)}[{i}]", self._error)

    def _list(self, key: str, default: Any) -> list[Any] | tuple[Any, ...]:
        value = self._get(key, default)
        if not isinstance(value, (list, tuple)):
            raise self.fail(key, f"expected a list, got {_show(value)}")
        return value

    def strings(self, key: str, default: Any = _MISSING) -> tuple[str, ...]:
        """A list of non-empty strings."""
        value = self._get(key, default)
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) and v for v in value):
            raise self.fail(key, f"expected a list of names, got {_show(value)}")
        return tuple(value)

    def reject_unknown(self, allowed: frozenset[str]) -> None:
        """Raise on any key not in ``allowed`` (catches typos in hand-written files)."""
        for key in self._data:
            if key not in allowed:
                raise self.fail(str(key), f"unknown key (allowed: {', '.join(sorted(allowed))})")


def _show(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
