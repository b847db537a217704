"""Algorithm 2's response protocols run against the simulator, one request per search.

:mod:`agents.caregiving.model.response` states what to do about a danger as a protocol: a generator that
yields each search it needs (an :class:`~agents.caregiving.model.response.Ask`) and is sent its answer.
:class:`SearchClient` runs such a protocol to its end, each search by one request to the simulator's
``imagine`` key, and hands a head start found on the way to its caller as soon as the progress reply that
carries it lands. It keeps the running estimate of a candidate's cost that each search is asked with
(:class:`~agents.caregiving.model.response.JudgingTime`) and, for the action agent's log lines, the moves
the latest response judged and the milliseconds it spent on requests and in the simulator.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Generator
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

from agents.caregiving.model import imagine_reply
from agents.caregiving.model.response import Ask, Asked, JudgingTime
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult, Verdict
from wm import Graph

from ..logs import AgentLogger
from .set_off import SetOff

T = TypeVar("T")


class Asker(Protocol):
    """The runtime's request call (:meth:`agents.runtime.Agent.ask`), as the client uses it."""

    def __call__(
        self,
        key: str,
        request: Any,
        *,
        decode: Callable[[Any], imagine_reply.ImagineReply],
        progress: Callable[[imagine_reply.ImagineReply], None] | None,
    ) -> Awaitable[imagine_reply.ImagineReply]: ...


@dataclass(frozen=True)
class SearchTerms:
    """What every search of one response is asked with besides its moves.

    Read at each search, as the response goes on: ``delay``, the simulated seconds after the context at which
    a move decided then would reach the world, and ``rate``, simulated seconds per wall second.
    """

    delay: Callable[[], float]
    rate: Callable[[], float]
    uncertainty: Uncertainty
    threshold: float
    max_moves: int

    @classmethod
    def reading(
        cls, g: Graph, time: float, set_off: SetOff, uncertainty: Uncertainty, threshold: float, max_moves: int
    ) -> SearchTerms:
        """The terms of searches on a context of ``time``, their delay and rate read from W as each one starts."""
        return cls(lambda: set_off.delay(g, time), lambda: set_off.clock.rate(g), uncertainty, threshold, max_moves)


class SearchClient:
    """Runs response protocols by asking the simulator for each search (see the module documentation)."""

    def __init__(self, ask: Asker, key: str, log: AgentLogger) -> None:
        self._ask, self._key, self._log = ask, key, log
        self.judging = JudgingTime()
        self.rpc_ms = self.sim_ms = 0.0
        self.tried: list[Verdict] = []  # the generated candidates the latest response judged

    def begin(self) -> None:
        """A new response: its requests, time and judged moves are counted afresh."""
        self.rpc_ms = self.sim_ms = 0.0
        self.tried = []

    async def run(
        self,
        protocol: Generator[Ask, Asked, T],
        terms: SearchTerms,
        lead: Callable[[Verdict], None] | None = None,
        led: Callable[[], bool] = lambda: False,
    ) -> T:
        """Run ``protocol`` to its end, each search it asks for by the simulator; a head start found on the way
        goes to ``lead``, and ``led`` tells the protocol whether one was written."""
        try:
            ask = next(protocol)
            while True:
                found = await self._search(ask, terms, lead if ask.head_start else None)
                ask = protocol.send(Asked(found, led()))
        except StopIteration as done:
            ended: T = done.value
            return ended

    async def _search(
        self, ask: Ask, terms: SearchTerms, head_start: Callable[[Verdict], None] | None
    ) -> SearchResult | None:
        """One search, each candidate imagining the robot starting when its command would arrive; None when the
        simulator refused it."""
        item = ask.item(
            terms.delay(), terms.uncertainty, terms.threshold, terms.max_moves, self.judging.seconds * terms.rate()
        )

        def progress(reply: imagine_reply.ImagineReply) -> None:
            found = reply.search
            if head_start is not None and found is not None and found.lead is not None:
                head_start(found.lead)

        sent = time.perf_counter()
        reply = await self._ask(self._key, {"items": [item.to_wire()]}, decode=imagine_reply.decode, progress=progress)
        self.rpc_ms += (time.perf_counter() - sent) * 1e3
        self.sim_ms += reply.compute_ms
        found = reply.search
        if found is None:
            self._log.error("the simulator refused the search", error=reply.results[0].error if reply.results else None)
            return None
        self.judging.timed(ask, found, reply.compute_ms)
        if ask.moves is None:
            self.tried += found.verdicts
        return found
