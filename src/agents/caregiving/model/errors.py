"""Typed errors raised on purpose by the caregiving core."""

from __future__ import annotations


class CaregivingError(Exception):
    """Base class of every error the caregiving core raises on purpose."""


class ScenarioError(CaregivingError, ValueError):
    """A scenario file is malformed; the message starts with the offending key path."""


class RequestError(CaregivingError, ValueError):
    """An imagine request or a wire message is malformed or names unknown entities."""


class ReplyError(CaregivingError, ValueError):
    """An imagine reply is malformed (:mod:`agents.caregiving.model.imagine_reply`)."""


class RecordingError(CaregivingError, ValueError):
    """A file of recorded batches is not one (:mod:`agents.caregiving.model.recorded_batch`)."""
