"""Algorithm 2's search input as the pipeline would build it with perfect belief, for benches and tests.

The ground truth of a trial at a moment is the context: no sensor noise. Each person the idle world
sees fall is a danger, imagined as the intention agent imagines it (their planned walk at their true
gaze, around the objects they have truly seen so far), with every gaze class of theirs to judge moves
at, the class of their true gaze first. This separates what the move search can do from what
perception's noise costs.
"""

from __future__ import annotations

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.move_search import SearchSpec
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import Scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.visibility import WALL_KIND, gaze_classes
from agents.caregiving.model.world_model import World

from .oracle import world_at


def perfect_belief_spec(
    trial: Scenario, at: float, planner: GridPlanner, delay: float
) -> tuple[Scene, SearchSpec] | None:
    """The exact scene at ``at`` and the spec of its dangers, the robot starting ``delay`` s later; None if none.

    Each endangered person knows the objects they have truly seen by then, as the intention agent's
    ``knows`` edges would hold them.
    """
    idle = World.from_scenario(trial, planner=planner)
    outcome = idle.run(60.0)
    now = world_at(trial, at, planner)
    scene = now.scene()
    objects = {o.name for o in scene.obstacles if o.kind != WALL_KIND}
    dangers: list[Danger] = []
    gazes: dict[str, tuple[float, ...]] = {}
    known: dict[str, tuple[str, ...]] = {}
    for c in outcome.collisions:
        walker = idle.walker(c.person)
        if c.person in gazes:
            continue
        seen = tuple(sorted(objects & now.walker(c.person).known.keys()))
        danger = Danger.of(imagine_person(scene, c.person, walker.target, walker.gaze, known=seen))
        if danger is None:
            continue
        dangers.append(danger)
        classes = gaze_classes(scene.person(c.person), scene.bodies_around(c.person))
        gazes[c.person] = tuple(sorted((g.gaze for g in classes), key=lambda g: abs(g - walker.gaze)))
        known[c.person] = seen
    if not dangers:
        return None
    return scene, SearchSpec(tuple(dangers), gazes, known, (), None, delay)
