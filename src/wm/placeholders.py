"""``${NAME}`` and ``${NAME:-default}`` placeholders, expanded the same way everywhere.

Launch files (:mod:`wm.launch.spec`) and Zenoh config files
(:mod:`wm.net.zenoh_config`) both use them. A placeholder takes the value of
``NAME`` when one is given, else its default; one with neither is reported to
the caller's ``on_missing`` and left as it is, so that a caller can name every
missing variable at once.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any

PLACEHOLDER = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)(?::-([^}]*))?\}")

Render = Callable[[str, Any], str]


def _as_text(name: str, value: Any) -> str:
    return str(value)


_MISSING = object()


def _value(match: re.Match[str], variables: Mapping[str, Any], on_missing: Callable[[str], None]) -> Any:
    name, default = match.group(1), match.group(2)
    if name in variables:
        return variables[name]
    if default is not None:
        return default
    on_missing(name)
    return _MISSING


def expand(
    text: str,
    variables: Mapping[str, Any],
    on_missing: Callable[[str], None],
    render: Render = _as_text,
) -> str:
    """``text`` with every placeholder replaced by ``render(NAME, value)`` or by its default."""

    def replace(match: re.Match[str]) -> str:
        value = _value(match, variables, on_missing)
        return match.group(0) if value is _MISSING else render(match.group(1), value)

    return PLACEHOLDER.sub(replace, text)


def expand_value(
    text: str,
    variables: Mapping[str, Any],
    on_missing: Callable[[str], None],
    render: Render = _as_text,
) -> Any:
    """As :func:`expand`, but a ``text`` that is one placeholder and nothing else
    becomes the variable's value itself, of whatever type (a list stays a list)."""
    match = PLACEHOLDER.fullmatch(text)
    if match is None:
        return expand(text, variables, on_missing, render)
    value = _value(match, variables, on_missing)
    return text if value is _MISSING else value
