"""Algorithm 2's search input as the pipeline would build it with perfect belief, for benches and tests.

The ground truth of a trial at a moment is the context: no sensor noise. Each person the idle world
sees fall is a danger, imagined as the intention agent imagines it (their planned walk at their true
gaze, around the objects they have truly seen so far), with every gaze class of theirs to judge moves
at, the class of their true gaze first; everyone else still walking walks to their true target beside
them. This separates what the move search can do from what perception's noise costs. :func:`spec_on`
also finds the dangers on a belief as Algorithm 1 does, knowing nothing of the true gaze nor of what each
person truly saw (:attr:`Gazes.SOONEST`), as the closed loop does (:mod:`bridges.experiment.closed_loop`).
:func:`outcome_in_truth` then commands the search's moves in the ground truth when the search sends them.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from enum import Enum

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import Scenario
from agents.caregiving.model.scene import Pose, Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.verdict import SearchResult
from agents.caregiving.model.visibility import WALL_KIND, gaze_classes
from agents.caregiving.model.world_model import Outcome, Walk, World

from .oracle import commanded, idle_run, world_at


class Gazes(Enum):
    """The gaze each person's danger is found at, and the gazes their moves are judged at."""

    #: Found at the true gaze; judged at every gaze class, the nearest the true gaze first.
    CLASSES = "classes"
    #: Found at the first gaze class whose walk collides, the nearest the true gaze first, as Algorithm 1 would
    #: find it on a belief where the true gaze shows no danger; judged at every class, that one first.
    ANY_CLASS = "any-class"
    #: Found and judged at the true gaze alone: a robot that knew how far ahead each person looks, which shows
    #: what not knowing it costs.
    TRUE_GAZE = "true-gaze"
    #: Found as Algorithm 1 finds it on a belief, knowing nothing of the true gaze: at the gaze class whose walk
    #: collides soonest (:func:`agents.caregiving.model.guesses.summarise`); judged at every class, that one
    #: first, in the order :func:`agents.caregiving.robot_intentions.risky_first` gives.
    SOONEST = "soonest"


def perfect_belief_spec(
    trial: Scenario, at: float, planner: GridPlanner, delay: float, gazes: Gazes = Gazes.CLASSES
) -> tuple[Scene, SearchSpec] | None:
    """The exact scene at ``at`` and the spec of its dangers, the robot starting ``delay`` s later; None if none.

    Each endangered person knows the objects (and the robot) they have truly seen by then, as the intention
    agent's ``knows`` edges would hold them. ``gazes`` is :func:`spec_on`'s.
    """
    idle = idle_run(trial, planner)
    now = world_at(trial, at, planner)
    scene = now.scene()
    spec = spec_on(scene, idle, now, delay, gazes)
    return (scene, spec) if spec is not None else None


def spec_on(
    scene: Scene,
    idle: World,
    now: World,
    delay: float,
    gazes: Gazes = Gazes.CLASSES,
    people: Sequence[str] | None = None,
    surely_seen: Mapping[str, Iterable[str]] | None = None,
    robot_at: Mapping[str, Pose] | None = None,
) -> SearchSpec | None:
    """The spec of the dangers Algorithm 1 finds on ``scene`` (exact or believed) for the people who fall in ``idle``
    (or for ``people``: on a belief, someone who falls in no truth may seem to, a false alarm), but those who
    have already fallen by ``now``: they lie where they fell, as perception sees them, and walk nowhere. Nor is
    a walk that touches at once on ``scene`` a danger: it is due, and the action agent no longer searches it.

    ``idle`` is the trial run to its end with the robot idle, ``now`` the truth at the scene's moment: what each
    person has seen so far, unless ``surely_seen`` says what each has surely seen, and where they remember the
    robot, unless ``robot_at`` says it, as Algorithm 1 holds them.
    ``gazes`` says at which gaze each person's walk is imagined, and at which their moves are judged
    (:class:`Gazes`).
    """
    any_class = gazes in (Gazes.ANY_CLASS, Gazes.SOONEST)
    # What the intention agent's ``knows`` edges can hold: the objects and the robot.
    objects = {o.name for o in scene.obstacles if o.kind != WALL_KIND} | {scene.robot_name}
    dangers: list[Danger] = []
    judged_at: dict[str, tuple[float, ...]] = {}
    known: dict[str, tuple[str, ...]] = {}
    remembered: dict[str, Pose] = {}
    lying = now.fallen()
    for name in [c.person for c in idle.outcome().collisions] if people is None else people:
        if name in judged_at or name in lying:
            continue
        walker = idle.walker(name)
        sure = surely_seen.get(name, ()) if surely_seen is not None else now.walker(name).known
        seen = tuple(sorted(objects & set(sure)))
        classes = gaze_classes(scene.person(name), scene.bodies_around(name))
        if gazes is Gazes.SOONEST:
            order = tuple(g.gaze for g in classes)
            imagined = ((Danger.of(imagine_person(scene, name, walker.target, g, known=seen)), g) for g in order)
            met = [(d, g) for d, g in imagined if d is not None]
            if not met:
                continue
            danger, gaze = min(met, key=lambda m: m[0].time_to_collision)
        else:
            order = tuple(sorted((g.gaze for g in classes), key=lambda g: abs(g - walker.gaze)))
            for gaze in order if any_class else (walker.gaze,):
                danger = Danger.of(imagine_person(scene, name, walker.target, gaze, known=seen))
                if danger is not None:
                    break
            else:
                continue
        if danger.time_to_collision <= 0.0:
            continue  # touching already on this belief: a danger due, which the action agent no longer searches
        dangers.append(danger)
        if gazes is Gazes.TRUE_GAZE:
            judged_at[name] = (walker.gaze,)
        else:
            judged_at[name] = (gaze, *(g for g in order if g != gaze)) if any_class else order
        known[name] = seen
        pose = robot_at.get(name) if robot_at is not None else now.robot_memory(name)
        if pose is not None and scene.robot_name in seen:
            remembered[name] = pose
    if not dangers:
        return None
    # The others walk to their true targets beside them, as the action agent imagines them on their likeliest walk.
    bystanders = walks_on(scene, now, [name for name in now.walking() if name not in judged_at])
    return SearchSpec(tuple(dangers), judged_at, known, bystanders, None, delay, robot_at=remembered)


def walks_on(scene: Scene, now: World, people: Iterable[str]) -> tuple[Walk, ...]:
    """Each of ``people``'s walk in the truth ``now`` (their target and gaze), knowing the objects and the robot
    of ``scene`` they have seen so far, the robot where they remember it."""
    objects = {o.name for o in scene.obstacles if o.kind != WALL_KIND} | {scene.robot_name}
    walkers = (now.walker(name) for name in people)
    return tuple(
        Walk(w.state.name, w.target, w.gaze, tuple(sorted(objects & w.known.keys())), now.robot_memory(w.state.name))
        for w in walkers
    )


def outcome_in_truth(
    trial: Scenario, at: float, planner: GridPlanner, delay: float, judging: float, result: SearchResult
) -> Outcome | None:
    """How ``trial`` ends with the search's moves commanded in its ground truth when the search sends them; None
    when it sends none, or the robot cannot reach the move.

    The search started at ``at`` with the robot starting ``delay`` later, and ``judging`` seconds more per
    judgement. A head start is commanded when the search says it set off (``lead_sets_off``), and the
    chosen move (if any) replaces it when the search ends; with no move chosen, the robot brakes when
    the search ends (when the search found braking harmless) or drives the head start on.
    """
    chosen = result.chosen.move if result.chosen is not None else None
    lead = result.lead.move if result.lead is not None else None
    ended = at + delay + judging * result.judged
    if lead is None or result.lead_sets_off is None:
        if chosen is None:
            return None
        return commanded(world_at(trial, ended, planner), chosen)
    world = world_at(trial, at + result.lead_sets_off, planner)
    if not world.command_robot(lead):
        return None
    if chosen is not None:
        world.advance(ended)
        return commanded(world, chosen)
    if result.halt is not None:
        world.advance(ended)
        world.command_robot(None)
    return world.run(world.time + 30.0)


def saved_in_truth(
    trial: Scenario, at: float, planner: GridPlanner, delay: float, judging: float, result: SearchResult
) -> bool:
    """Whether the search's moves, commanded as :func:`outcome_in_truth` commands them, leave everybody untouched."""
    outcome = outcome_in_truth(trial, at, planner, delay, judging, result)
    return outcome is not None and not outcome.collided
