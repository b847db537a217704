"""The typed errors of the working memory.

Every error the library raises on purpose derives from :class:`WMError`, so an
agent can catch one type and keep running. Nothing is written when one of these
is raised.
"""

from __future__ import annotations


class WMError(Exception):
    """Base class of every error raised by the working memory on purpose."""


class OntologyError(WMError):
    """The ontology file itself is malformed; the message names the offending key."""


class ValidationError(WMError):
    """A write that the ontology refuses."""


class UnknownTypeError(ValidationError):
    """A node or edge type the ontology does not declare."""


class UnknownAttributeError(ValidationError):
    """An attribute the ontology does not allow on that node or edge type."""


class AttributeTypeError(ValidationError):
    """A value of the wrong type (or length) for its attribute."""


class NotFoundError(WMError, KeyError):
    """A node or edge that does not exist (or no longer exists)."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class NodeNotFoundError(NotFoundError):
    """No live node has this id or name."""


class EdgeNotFoundError(NotFoundError):
    """No visible edge has this (src, dst, type) key."""


class NameExistsError(WMError):
    """A node with this name already exists."""


class NodeExistsError(WMError):
    """A node with this id already exists, or was deleted and may not come back."""


class RTError(WMError):
    """An RT edge that would break the RT tree (a cycle or a second parent), or no RT path."""


class DecodeError(WMError):
    """Bytes that do not decode as a valid message or scene."""


class SceneFormatError(WMError):
    """A JSON scene file that is neither our format nor DSR's, or is inconsistent."""


class PluginError(WMError):
    """An installed plugin (a ``wm.commands`` or ``wm.ontologies`` entry point) that cannot be loaded or used."""
