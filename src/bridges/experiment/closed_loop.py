"""Algorithm 2 in a closed loop on noisy beliefs, in process: every look at a danger answered, carried out in the truth.

Live, the action agent looks again each time Algorithm 1 rewrites a danger while
it lasts: it judges the move under way again from the robot's current state and
keeps it, doubts it or replaces it (:mod:`agents.caregiving.model.response`).
:func:`closed_loop` runs that loop on a trial's ground truth, from the moment its
danger showed:

* every :attr:`Setup.look` seconds, perception's belief of the truth is drawn
  (:mod:`bridges.experiment.beliefs`), each object's size bias and the direction
  of its position error drawn once per trial and kept (a bias the tracker never
  averages away, and an average that only tightens), the people's errors drawn
  anew at each look;
* Algorithm 1's danger is imagined on that belief
  (:func:`~bridges.experiment.perfect_belief.spec_on`) as it finds it live, knowing
  nothing of the true gaze: at the gaze class whose walk collides soonest, each
  person knowing the objects they have surely seen (in every gaze class) at the
  looks so far and along their walk before the first, and the robot where they
  last surely saw it, kept at every sensor frame as the intention agent keeps it
  (between looks on the truth's positions, no belief being drawn there); a person
  whose danger no move removed is looked at again only after :attr:`Setup.retry`
  seconds, as live;
* :func:`~agents.caregiving.model.response.respond` is driven with the real search
  on the belief, the robot starting :attr:`Setup.delay` seconds after the look and
  :attr:`Setup.judging` seconds later per judgement, and its moves are commanded in
  the ground truth when they would be sent: a head start after its own judgement,
  the move chosen (or braking) when the response ends, or when its search imagined
  it setting off if that is later (a move ending well before that is judged again
  to set off sooner, as the action agent does). With :attr:`Setup.judged_in`, a
  judgement truly takes that long while the search imagines ``judging``: what an
  estimate of a candidate's cost that is off does;
* it looks on until nobody walks any more (or :data:`HORIZON` has passed): after
  someone falls, at the others, as live. Someone lying where they fell is no
  danger any more, as perception sees them lying;
* with :attr:`Setup.assist`, a look that finds no danger, with the robot at rest and
  someone lying where they fell, sends the robot to them as the assist agent does
  (:mod:`agents.caregiving.model.go_to`, the walkers on their true walks): what
  answering a fall costs the others.

With :attr:`Setup.first_look_only`, only the first look acts and its move is driven
on: what looking again buys.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.fields import Fields
from agents.caregiving.model.go_to import GAP, going_to
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES, SearchItem
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.response import (
    Ask,
    Asked,
    Keep,
    NoMove,
    Policy,
    Send,
    UnderWay,
    drive,
    respond,
    set_off_sooner,
)
from agents.caregiving.model.robot_memory import remembered_robot
from agents.caregiving.model.robot_moves import RobotMove, moves_beside
from agents.caregiving.model.rollout import DT
from agents.caregiving.model.scenario import Scenario, SensorSpec
from agents.caregiving.model.scene import Pose, Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.visibility import gaze_classes, surely_seen
from agents.caregiving.model.world_model import World

from .beliefs import SAMPLES, Noise, belief, search_uncertainty
from .oracle import idle_run, world_at
from .perfect_belief import Gazes, spec_on, walks_on

#: Seconds past the danger's moment after which a trial's loop stops looking (the truth then runs to its end).
HORIZON = 10.0


@dataclass(frozen=True, kw_only=True)
class Setup:
    """How the loop runs: the robot's start ``delay`` after a look and ``judging`` seconds more per judgement,
    seconds between ``look``s at a danger and before a ``retry`` of one no move removed, whether only the first
    look acts, the belief's ``noise``, the risk ``threshold`` a move must stay under, and the ``max_moves`` a
    search judges at most; ``judged_in``, the seconds a judgement truly takes (``None``: ``judging``, the
    search's estimate). With ``known_gaze``
    the search judges each move at the endangered people's true gaze alone (see
    :class:`~bridges.experiment.perfect_belief.Gazes`), which no sensor tells. With ``false_alarms``, Algorithm 1
    looks at everyone still walking, as live, not only at those who fall with the robot idle: anyone whose walk
    on the belief collides is a danger, a false alarm when they pass in the truth."""

    delay: float
    judging: float
    look: float
    retry: float
    first_look_only: bool
    noise: Noise
    threshold: float = 0.2
    known_gaze: bool = False
    false_alarms: bool = False
    max_moves: int = DEFAULT_MAX_MOVES
    assist: bool = False
    judged_in: float | None = None

    def __post_init__(self) -> None:
        if self.judged_in is not None and (self.judged_in < 0.0 or self.judging <= 0.0):
            raise ValueError("a judgement's true time needs an estimate of it (judging > 0), and is not negative")

    def after(self, judged: int) -> float:
        """When a response that has made ``judged`` judgements truly ends, in seconds after its look."""
        return self.delay + (self.judging if self.judged_in is None else self.judged_in) * judged

    def truly(self, at: float, delay: float) -> float:
        """When a search started ``delay`` after the look truly reaches the moment it imagined ``at`` after it."""
        return at if self.judged_in is None else delay + (at - delay) * self.judged_in / self.judging


@dataclass
class Loop:
    """One draw's closed loop: the truth, the move under way, and what happened."""

    truth: World
    idle_fallers: frozenset[str] = frozenset()  # who falls in the truth with the robot idle
    under_way: UnderWay | None = None
    retry_after: float = -math.inf
    looks: int = 0
    # The commands the robot took: when sent (the world acts on one at its next step), which move (None: braking).
    commanded: list[tuple[float, RobotMove | None]] = field(default_factory=list)
    judged: int = 0
    responses: dict[str, int] = field(default_factory=dict)
    gone_to: str | None = None  # whom the robot was sent to, lying where they fell
    seen: dict[str, set[str]] = field(default_factory=dict)  # what each person has surely seen, as Algorithm 1 holds
    robot_at: dict[str, Pose] = field(default_factory=dict)  # where each remembers the robot, as Algorithm 1 keeps it
    first_risk: float | None = None  # the sampled risk of the first move a search chose and sent (not braking)

    @property
    def commands(self) -> int:
        """How many commands the robot took."""
        return len(self.commanded)


@dataclass(frozen=True)
class Perception:
    """Draws beliefs of one trial's truth: the objects' errors drawn once, the people's anew at every look."""

    sensors: SensorSpec
    noise: Noise
    seed: tuple[int, ...]

    def belief(self, truth: Scene, at: float, look: int) -> Scene:
        """The belief at the ``look``-th look, ``at`` seconds into the trial."""
        objects = belief(truth, self.sensors, at, self.noise, *self._rngs(0))
        people = belief(truth, self.sensors, at, self.noise, *self._rngs(look + 1))
        return replace(objects, people=people.people)

    def uncertainty(self, scene: Scene, at: float, look: int) -> Uncertainty:
        """What the action agent samples round the belief at the ``look``-th look."""
        return search_uncertainty(scene, self.sensors, at, look, self.noise)

    def _rngs(self, stream: int) -> tuple[np.random.Generator, np.random.Generator]:
        return np.random.default_rng([*self.seed, stream]), np.random.default_rng([*self.seed, stream, 1])


def closed_loop(trial: Scenario, at: float, planner: GridPlanner, seed: tuple[int, ...], setup: Setup) -> Loop:
    """Run ``trial`` in a closed loop from ``at`` (when the danger showed), its beliefs drawn from ``seed``; the
    returned loop's truth has run to its end."""
    idle = idle_run(trial, planner)
    loop = Loop(world_at(trial, at, planner), frozenset(c.person for c in idle.outcome().collisions))
    perception = Perception(trial.sensors, setup.noise, seed)
    policy = Policy(setup.threshold, SAMPLES, trial.scene().robot_name)
    now = at
    _saw_before(loop, perception.belief(loop.truth.scene(), now, 0))
    frame = 1.0 / trial.sensors.rate_hz
    while not loop.truth.done and now < at + HORIZON:
        if now >= loop.retry_after and (loop.looks == 0 or not setup.first_look_only):
            scene = perception.belief(loop.truth.scene(), now, loop.looks)
            _saw(loop, scene)
            _look(loop, scene, perception.uncertainty(scene, now, loop.looks), idle, now, policy, setup)
        then, now = now, max(now + setup.look, loop.truth.time)
        for k in range(1, math.ceil((now - then) / frame - 1e-9)):
            loop.truth.advance(then + k * frame)
            _saw_robot(loop, loop.truth.scene())
        loop.truth.advance(now)
    loop.truth.run(60.0)
    return loop


#: Steps of a person's walk before the first look between the poses Algorithm 1 is taken to have seen them at.
TRACKED_EVERY = 5


def _saw(loop: Loop, scene: Scene) -> None:
    """Add what each person in ``scene`` sees at every gaze class of theirs to what they have surely seen, and
    where they have seen the robot so."""
    for p in scene.people:
        loop.seen.setdefault(p.name, set()).update(surely_seen(gaze_classes(p, scene.bodies_around(p.name))))
    _saw_robot(loop, scene)


def _saw_robot(loop: Loop, scene: Scene) -> None:
    """Where each person in ``scene`` remembers the robot after this frame, as Algorithm 1 keeps it at every frame
    (:func:`~agents.caregiving.model.robot_memory.remembered_robot`)."""
    if scene.robot is None:
        return
    for p in scene.people:
        pose = remembered_robot(loop.robot_at.get(p.name), p, scene.robot)
        if pose is not None:
            loop.robot_at[p.name] = pose


def _saw_before(loop: Loop, scene: Scene) -> None:
    """What each person surely saw along their walk before the first look (``scene``, a belief then): Algorithm 1
    marks it from the moment it tracks them, every frame."""
    for p in scene.people:
        track = loop.truth.walker(p.name).track
        for k in range(0, len(track) - 1, TRACKED_EVERY):
            (x, y), (nx, ny) = track[k], track[k + 1]
            was = p.moved(x, y, math.atan2(ny - y, nx - x) if (nx, ny) != (x, y) else p.heading)
            at = replace(scene, people=tuple(was if q.name == p.name else q for q in scene.people))
            _saw(loop, at)


def _look(
    loop: Loop, scene: Scene, uncertainty: Uncertainty, idle: World, now: float, policy: Policy, setup: Setup
) -> None:
    """One look: Algorithm 1's danger on ``scene``, Algorithm 2's response to it, carried out in the truth."""
    people = loop.truth.walking() if setup.false_alarms else None
    if setup.known_gaze:
        spec = spec_on(scene, idle, loop.truth, setup.delay, Gazes.TRUE_GAZE, people)
    else:
        spec = spec_on(scene, idle, loop.truth, setup.delay, Gazes.SOONEST, people, loop.seen, loop.robot_at)
    if spec is None:
        if setup.assist:
            _go_to_someone_fallen(loop, scene, uncertainty, now, setup)
        return
    loop.looks += 1
    spec = replace(spec, current=loop.under_way.move if loop.under_way is not None else None)
    judged = 0
    lead: tuple[float, RobotMove] | None = None

    def run(ask: Ask) -> Asked:
        nonlocal judged, lead
        delay = setup.after(judged)
        item = _as_served(ask.item(delay, uncertainty, setup.threshold, setup.max_moves, setup.judging))
        found = item.run(scene, partial(serve_one, scene), None, (lambda _lead: None) if ask.head_start else None)
        if found.lead is not None and found.lead.move is not None and found.lead_sets_off is not None:
            lead = (now + setup.truly(found.lead_sets_off, delay), found.lead.move)
        judged += found.judged
        return Asked(found, led=found.lead is not None)

    response = drive(respond(spec, {d.person: 1.0 for d in spec.dangers}, loop.under_way, policy), run)
    if lead is not None:
        loop.under_way = UnderWay(lead[1], second_look=True)
    if isinstance(response, Send) and _early(response, judged, setup) > 2 * setup.judging:
        sooner = replace(spec, current=loop.under_way.move if loop.under_way is not None else None)
        response = drive(set_off_sooner(response, sooner, 1.0, policy), run)
    loop.judged += judged
    ended = now + setup.after(judged)
    kind = type(response).__name__.lower() + ("_doubted" if isinstance(response, Keep) and response.doubted else "")
    loop.responses[kind] = loop.responses.get(kind, 0) + 1
    if lead is not None:
        _command(loop, *lead)
    match response:
        case Keep(doubted=doubted, best_new=None) if loop.under_way is not None:
            loop.under_way = replace(loop.under_way, second_look=doubted)
        case Send(chosen, braking=braking, sets_off=sets_off):
            if not braking and loop.first_risk is None:
                loop.first_risk = chosen.risk
            _command(loop, _held(now, ended, sets_off), chosen.move)
            loop.under_way = UnderWay(chosen.move, second_look=False)
            if braking:
                loop.retry_after = now + setup.retry
        case NoMove(halt, sets_off):
            if halt is not None and lead is not None:
                _command(loop, _held(now, ended, sets_off), None)
                loop.under_way = UnderWay(None, second_look=True)
            loop.retry_after = now + setup.retry


def _held(now: float, ended: float, sets_off: float | None) -> float:
    """When a move whose response ended at ``ended`` goes out: then, or, if later, at the moment its search imagined
    it setting off (``sets_off`` after the look at ``now``), as the agents hold their moves."""
    return max(ended, now + sets_off) if sets_off is not None else ended


def _early(send: Send, judged: int, setup: Setup) -> float:
    """How long before the moment its search imagined ``send`` setting off (after the look) its response ended,
    ``judged`` judgements in, give or take the world's step (:meth:`agents.caregiving.set_off.SetOff.early`)."""
    if send.braking or send.unsaved or send.sets_off is None:
        return 0.0
    return send.sets_off - setup.after(judged) - DT


def _as_served(item: SearchItem) -> SearchItem:
    """``item`` as the simulator reads it off the wire: a request it would refuse live fails here too."""
    return SearchItem.from_fields(Fields(item.to_wire(), "search", RequestError))


def _go_to_someone_fallen(loop: Loop, scene: Scene, uncertainty: Uncertainty, now: float, setup: Setup) -> None:
    """Send the robot, at rest, to the first person lying where they fell, as the assist agent does: the first pose
    beside them that harms nobody walking on the belief ``scene`` (the nearest, with nobody walking)."""
    robot = loop.truth.scene().robot
    lying = sorted(loop.truth.fallen() & {p.name for p in scene.people})
    if loop.gone_to is not None or not lying or robot is None or robot.speed > 0.0:
        return
    moves = moves_beside(scene, lying[0], GAP)
    spec = SearchSpec((), {}, {}, walks_on(scene, loop.truth, loop.truth.walking()))
    if not moves or not spec.bystanders:
        return

    def run(ask: Ask) -> Asked:
        item = _as_served(ask.item(setup.delay, uncertainty, setup.threshold, setup.max_moves, setup.judging))
        return Asked(item.run(scene, partial(serve_one, scene)))

    found = drive(going_to(spec, moves), run)
    loop.judged += found.judged if found is not None else 0
    if found is None or found.chosen is None:
        return
    _command(loop, _held(now, now + setup.after(found.judged), found.sets_off), found.chosen.move)
    loop.under_way, loop.gone_to = UnderWay(found.chosen.move, second_look=True), lying[0]
    loop.responses["go_to"] = loop.responses.get("go_to", 0) + 1


def _command(loop: Loop, at: float, move: RobotMove | None) -> None:
    loop.truth.advance(at)
    if loop.truth.command_robot(move):
        loop.commanded.append((at, move))
