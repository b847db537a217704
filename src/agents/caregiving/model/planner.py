"""Grid path planning for walkers (people and the robot) in a room.

The room is rasterised at 5 cm. Only the obstacles handed in are drawn, each
inflated by the walker's radius plus a small safety margin; the inflated mask of
every (obstacle, radius) pair is cached, so replanning after a gaze or pose change
only ORs cached masks. Optimal A* (octile costs 70/99) runs from every free goal
cell to the start at once (an unreachable start costs one flood of the goals' side
of the grid, which is rare, instead of a labelling of the grid on every plan):
``tcod.path.path2d``'s search, step for step, on a pathfinder whose buffers are
reused (:class:`_AStar`). A plan depends only on the grid, the goals and the start
(never on what was planned before): the world and the robot's imagination of it
plan alike. The cell path is string-pulled into a short
polyline in metres. A point goal in clear line of sight from the start skips
the search: the string-pulled path would be that straight segment anyway.

Since a plan depends only on its inputs, walks to objects are also remembered
by their exact inputs (start, target, obstacles, radius): the candidates of one
move search imagine the same person from the same start many times over, and
about a third of their plans repeat one already made.
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import numpy as np
import tcod.path
from numpy.typing import NDArray
from scipy import ndimage

from .geometry import FloatArray, Shape, aabb, grid_distance, nearest_segment, polyline_length
from .scene import Obstacle

_EIGHT = np.ones((3, 3), dtype=bool)
K = TypeVar("K")
V = TypeVar("V")
_CARDINAL, _DIAGONAL = 70, 99
#: How far (m) a walker may stand from the route planned where their walk began and still be walking it.
ON_ROUTE = 0.1


@dataclass(frozen=True)
class Plan:
    """A planned walk: ``path`` is an ``(N, 2)`` polyline in metres, empty when unreachable."""

    reachable: bool
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    length: float = math.inf


UNREACHABLE = Plan(False)


@dataclass(frozen=True)
class _Mask:
    i0: int
    j0: int
    cells: NDArray[np.bool_]


class _Recent(Generic[K, V]):
    """A bounded map that forgets its least recently used entry first."""

    def __init__(self, size: int) -> None:
        self._items: OrderedDict[K, V] = OrderedDict()
        self._size = size

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key: K) -> V | None:
        value = self._items.get(key)
        if value is not None:
            self._items.move_to_end(key)
        return value

    def put(self, key: K, value: V) -> None:
        self._items[key] = value
        if len(self._items) > self._size:
            self._items.popitem(last=False)

    def clear(self) -> None:
        self._items.clear()


class GridPlanner:
    """Occupancy-grid planner over fixed room bounds with a per-obstacle inflation cache."""

    def __init__(
        self,
        bounds: tuple[float, float, float, float],
        resolution: float = 0.05,
        margin: float | None = None,
        cache_size: int = 4096,
    ) -> None:
        self.bounds = bounds
        self.resolution = resolution
        self.margin = resolution if margin is None else margin
        self.shape = (
            int(math.ceil((bounds[2] - bounds[0]) / resolution)),
            int(math.ceil((bounds[3] - bounds[1]) / resolution)),
        )
        self._cache: _Recent[tuple[Shape, float], _Mask] = _Recent(cache_size)
        self._rings: _Recent[tuple[Shape, float], NDArray[np.intp]] = _Recent(cache_size)
        self._plans: _Recent[tuple[object, ...], Plan] = _Recent(cache_size)
        self._astar_search = _AStar(self.shape)
        self._origin = np.array(bounds[:2], dtype=np.float64)
        self._last_cell = np.array(self.shape, dtype=np.intp) - 1
        self.cache_hits = 0
        self.cache_misses = 0

    # -- grid helpers -------------------------------------------------------------------------
    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The grid cell holding a point (clamped to the grid)."""
        i = int((x - self.bounds[0]) / self.resolution)
        j = int((y - self.bounds[1]) / self.resolution)
        return min(max(i, 0), self.shape[0] - 1), min(max(j, 0), self.shape[1] - 1)

    def centres(self, cells: NDArray[np.integer]) -> FloatArray:
        """Centres in metres of an ``(N, 2)`` array of cells."""
        return (np.asarray(cells, dtype=np.float64) + 0.5) * self.resolution + self.bounds[:2]

    def clear_cache(self) -> None:
        """Forget every cached inflated mask, goal ring and plan."""
        self._cache.clear()
        self._rings.clear()
        self.forget_plans()

    def forget_plans(self) -> None:
        """Forget the remembered walks only (the masks stay warm)."""
        self._plans.clear()

    def _inflated(self, shape: Shape, inflate: float) -> _Mask:
        key = (shape, round(inflate, 6))
        mask = self._cache.get(key)
        if mask is not None:
            self.cache_hits += 1
            return mask
        self.cache_misses += 1
        x0, y0, x1, y1 = aabb(shape)
        i0, j0 = self.cell_of(x0 - inflate, y0 - inflate)
        i1, j1 = self.cell_of(x1 + inflate, y1 + inflate)
        xs = (np.arange(i0, i1 + 1, dtype=np.float64) + 0.5) * self.resolution + self.bounds[0]
        ys = (np.arange(j0, j1 + 1, dtype=np.float64) + 0.5) * self.resolution + self.bounds[1]
        mask = _Mask(i0, j0, grid_distance(shape, xs, ys) <= inflate)
        self._cache.put(key, mask)
        return mask

    def blocked(self, obstacles: Sequence[Obstacle], radius: float) -> NDArray[np.bool_]:
        """Cells a walker of ``radius`` cannot occupy, given only ``obstacles``."""
        grid = np.zeros(self.shape, dtype=bool)
        for obs in obstacles:
            m = self._inflated(obs.shape, radius + self.margin)
            grid[m.i0 : m.i0 + m.cells.shape[0], m.j0 : m.j0 + m.cells.shape[1]] |= m.cells
        return grid

    # -- planning -----------------------------------------------------------------------------
    def plan_to_object(
        self, start: tuple[float, float], target: Obstacle, obstacles: Sequence[Obstacle], radius: float
    ) -> Plan:
        """Shortest walk from ``start`` to a free cell touching the target's inflated footprint (read-only path)."""
        key = (float(start[0]), float(start[1]), target, tuple(obstacles), radius)
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        others = [o for o in obstacles if o.name != target.name]
        grid = self.blocked([*others, target], radius)
        plan = self._search(start, grid, self._ring(target.shape, radius + self.margin))
        plan.path.flags.writeable = False  # shared by every caller that asks the same
        self._plans.put(key, plan)
        return plan

    def plan_walk(
        self,
        position: tuple[float, float],
        origin: tuple[float, float] | None,
        target: Obstacle,
        obstacles: Sequence[Obstacle],
        radius: float,
    ) -> Plan:
        """The walk to ``target`` of someone at ``position`` whose walk began at ``origin`` (``None``: unknown).

        A plan depends on where it starts (string pulling keeps the turns of the grid path from there), so a
        route planned afresh midway may part by some degrees from the one planned at the origin, which is the
        one a walker follows. While ``position`` lies within :data:`ON_ROUTE` of the origin's route, the walk
        is the rest of that route; otherwise (no origin, or the walker has left it) it is planned from
        ``position``.
        """
        if origin is not None:
            planned = self.plan_to_object(origin, target, obstacles, radius)
            rest = _rest_of(planned.path, position) if planned.reachable else None
            if rest is not None:
                return Plan(True, rest, polyline_length(rest))
        return self.plan_to_object(position, target, obstacles, radius)

    def _ring(self, shape: Shape, inflate: float) -> NDArray[np.intp]:
        """The cells just outside the shape's inflated footprint (the goals of a walk to it), cached with its mask."""
        key = (shape, round(inflate, 6))
        ring = self._rings.get(key)
        if ring is None:
            tm = self._inflated(shape, inflate)
            lo_i, lo_j = max(tm.i0 - 1, 0), max(tm.j0 - 1, 0)
            hi_i = min(tm.i0 + tm.cells.shape[0] + 1, self.shape[0])
            hi_j = min(tm.j0 + tm.cells.shape[1] + 1, self.shape[1])
            window = np.zeros((hi_i - lo_i, hi_j - lo_j), dtype=bool)
            ci, cj = tm.i0 - lo_i, tm.j0 - lo_j
            window[ci : ci + tm.cells.shape[0], cj : cj + tm.cells.shape[1]] = tm.cells  # masks lie inside the grid
            ring = np.argwhere(ndimage.binary_dilation(window, _EIGHT) & ~window) + (lo_i, lo_j)
            self._rings.put(key, ring)
        return ring

    def plan_to_point(
        self, start: tuple[float, float], goal: tuple[float, float], obstacles: Sequence[Obstacle], radius: float
    ) -> Plan:
        """Shortest walk from ``start`` to ``goal``; unreachable if the goal cell is blocked."""
        grid = self.blocked(obstacles, radius)
        goal_cell = self.cell_of(*goal)
        if (
            not grid[self.cell_of(*start)]
            and not grid[goal_cell]
            and self._clear(np.asarray(start, dtype=np.float64), self.centres(np.array([goal_cell])), grid, True)[0]
        ):
            # What A* and string pulling would return, without the search: the straight drive.
            path = np.array([start, goal], dtype=np.float64)
            return Plan(True, path, polyline_length(path))
        plan = self._search(start, grid, np.array([goal_cell]))
        if plan.reachable:
            path = plan.path.copy()
            path[-1] = goal  # end exactly on the goal rather than on its cell centre
            if len(path) == 1:
                path = np.vstack((plan.path, path))
            return Plan(True, path, polyline_length(path))
        return plan

    def _search(self, start: tuple[float, float], grid: NDArray[np.bool_], goals: NDArray[np.intp]) -> Plan:
        """The string-pulled shortest walk from ``start`` to the nearest of the ``goals`` cells (an ``(N, 2)`` array)."""
        start_cell = self._free_cell_near(start, grid)
        if start_cell is None:
            return UNREACHABLE
        cells = self._astar(grid, goals, start_cell)
        if cells is None:
            return UNREACHABLE
        pts = np.vstack((np.asarray(start, dtype=np.float64), self.centres(cells)))
        path = self._string_pull(pts, grid)
        return Plan(True, path, polyline_length(path))

    def _astar(
        self, grid: NDArray[np.bool_], goals: NDArray[np.intp], start_cell: tuple[int, int]
    ) -> NDArray[np.integer] | None:
        """Cells after ``start_cell`` to the nearest goal (A* from every goal at once), None if unreachable."""
        goal_cells = goals[~grid[goals[:, 0], goals[:, 1]]]
        if goal_cells.size == 0:
            return None
        return self._astar_search.path(grid, goal_cells, start_cell)

    def _free_cell_near(self, point: tuple[float, float], grid: NDArray[np.bool_]) -> tuple[int, int] | None:
        """The point's cell, or the nearest free cell within two cells when it is blocked."""
        i, j = self.cell_of(*point)
        if not grid[i, j]:
            return i, j
        lo_i, lo_j = max(i - 2, 0), max(j - 2, 0)
        free = np.argwhere(~grid[lo_i : i + 3, lo_j : j + 3]) + (lo_i, lo_j)
        if free.size == 0:
            return None
        d = np.hypot(*(self.centres(free) - point).T)
        best = free[int(np.argmin(d))]
        return int(best[0]), int(best[1])

    def _string_pull(self, pts: FloatArray, grid: NDArray[np.bool_]) -> FloatArray:
        """Keep only the waypoints needed for straight segments that stay on free cells."""
        if len(pts) <= 2:
            return pts
        # Candidate waypoints: the cells where the grid path turns, plus the goal.
        step = np.diff(pts[1:], axis=0)
        turns = np.flatnonzero(np.any(np.abs(np.diff(step, axis=0)) > 1e-9, axis=1)) + 2
        keys = np.concatenate(([1], turns, [len(pts) - 1]))
        out = [pts[0]]
        anchor = 0
        while anchor < len(pts) - 1:
            ahead = keys[keys > anchor]
            if self._clear(pts[anchor], pts[-1:], grid, anchor == 0)[0]:
                nxt = len(pts) - 1
            else:
                clear = np.flatnonzero(self._clear(pts[anchor], pts[ahead], grid, anchor == 0))
                nxt = int(ahead[clear[-1]]) if clear.size else anchor + 1
            out.append(pts[nxt])
            anchor = nxt
        return np.asarray(out)

    def _clear(
        self, origin: FloatArray, ends: FloatArray, grid: NDArray[np.bool_], skip_origin: bool
    ) -> NDArray[np.bool_]:
        """For each end point, whether the segment from ``origin`` crosses only free cells."""
        seg = ends - origin
        n = int(math.ceil(float(np.hypot(seg[:, 0], seg[:, 1]).max()) / (self.resolution / 2))) + 1
        t = _fractions(n)[int(skip_origin) :]  # the start itself may sit on a blocked cell
        samples = origin + seg[:, None, :] * t[None, :, None]
        idx = np.floor((samples - self._origin) / self.resolution).astype(np.intp)
        np.maximum(idx, 0, out=idx)
        np.minimum(idx, self._last_cell, out=idx)
        return ~grid[idx[..., 0], idx[..., 1]].any(axis=1)


def _rest_of(path: FloatArray, position: tuple[float, float]) -> FloatArray | None:
    """``position`` followed by the waypoints of ``path`` past its nearest point, or None if that is farther
    than :data:`ON_ROUTE` (or ``path`` is a single point)."""
    if len(path) < 2:
        return None
    k, gap = nearest_segment(path, *position)
    if gap > ON_ROUTE:
        return None
    p = np.asarray(position, dtype=np.float64)
    ahead = path[k + 1 :]
    ahead = ahead[np.hypot(*(ahead - p).T) > 1e-9]
    return np.vstack((p, ahead)) if len(ahead) else None


@functools.cache
def _fractions(n: int) -> FloatArray:
    """``np.linspace(0, 1, n)``, made once per ``n`` (read-only: every segment test shares it)."""
    t = np.linspace(0.0, 1.0, n)
    t.flags.writeable = False
    return t


class _AStar:
    """Optimal octile A* on one grid shape between goal cells and a start, reusing tcod's buffers.

    The same search as ``tcod.path.path2d(cost, start_points=goals, end_points=[start])``, step for step
    (so the same path among equally short ones), without rebuilding the graph and the pathfinder's arrays
    and adding the roots one Python call at a time on every plan. Like ``path2d``, it searches from the
    goals towards the start, or from the start towards the goal when there is only one.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self._cost = np.ones(shape, dtype=np.int8)  # tcod's graph reads this array in place
        self._finder = tcod.path.Pathfinder(
            tcod.path.SimpleGraph(cost=self._cost, cardinal=_CARDINAL, diagonal=_DIAGONAL)
        )
        self._unreached = np.iinfo(self._finder.distance.dtype).max

    def path(
        self, grid: NDArray[np.bool_], goals: NDArray[np.intp], start: tuple[int, int]
    ) -> NDArray[np.integer] | None:
        """Cells after ``start`` to the nearest of ``goals`` (free cells of ``grid``), None if unreachable.

        ``goals`` come in row-major order, as ``np.argwhere`` lists them: the order tcod takes the roots in
        from its distance array, so that ties between equally short paths break as in ``path2d``.
        """
        if len(goals) == 1:
            goal = (int(goals[0, 0]), int(goals[0, 1]))
            cells = self._from_roots(grid, np.array([start]), goal)
            return None if cells is None else cells[::-1][1:]
        cells = self._from_roots(grid, goals, start)
        return None if cells is None else cells[1:]

    def _from_roots(
        self, grid: NDArray[np.bool_], roots: NDArray[np.intp], target: tuple[int, int]
    ) -> NDArray[np.integer] | None:
        """The cells from ``target`` to the nearest root, both included; None if no root reaches it."""
        np.logical_not(grid, out=self._cost, casting="unsafe")
        self._cost[target] = 1  # the search's own end is always enterable, as in ``path2d``
        distance, traversal = self._finder.distance, self._finder.traversal
        distance.fill(self._unreached)
        ri, rj = roots[:, 0], roots[:, 1]
        distance[ri, rj] = 0
        traversal[ri, rj] = roots  # a root leads to itself; every other cell on the path is written by the search
        self._finder.rebuild_frontier()
        cells = self._finder.path_from(target)
        return None if distance[target] == self._unreached else cells
