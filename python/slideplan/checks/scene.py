"""``slideplan check-scene``: what stands between a new robot scene and its first plan, in plain lines
that name links, obstacles and parameters, before any plan is tried.

It asks what the planner asks, with the planner's own parts: whether the fingertip reaches the table
top (:func:`slideplan.plan.robot.table_reach`), which 1 cm stretches of each table edge admit a side
grasp the arm reaches and can lift (the planner's grasp map), and, at those grasps, whether the
pre-grasp ``grasp_backoff`` before them is reachable and clear; where an edge has no grasp at all, why
not at its middle (the hand against the table, no arm configuration, the arm in collision).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

from .. import _core
from ..errors import MeshWarning
from ..world.objects import ThinObject
from ..plan.config import PlannerConfig
from ..plan.robot import base_pose_matrix, robot_model, scene_collision_world, table_reach_map
from ..plan.planner import grasp_map
from ..world.scenes import Scene

MIN_REACH = 0.5  # below this share of the table reached, plans mostly time out without start roots
BACKOFFS = (0.05, 0.04, 0.03, 0.02, 0.01)  # shorter pre-grasp backoffs tried when the scene's fails (m)


@dataclasses.dataclass
class SceneCheck:
    """What check-scene found.

    Attributes:
        lines: the report, one finding per line, the causes of failure first.
        ok: the fingertip reaches at least :data:`MIN_REACH` of the table and some edge admits a side
            grasp with a clear pre-grasp.
        reach_points, reached: the table lattice of :func:`slideplan.plan.robot.table_reach_map` and
            whether the fingertip reaches each point.
        stretches: per 1 cm stretch of each edge, where its grasp frame is (x, y) and what it admits:
            ``clear`` (a side grasp with a clear pre-grasp), ``blocked`` (a grasp, but it or its
            pre-grasp is not clear) or ``none``.
    """

    lines: list[str]
    ok: bool
    reach_points: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    reached: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=bool))
    stretches: list[tuple[float, float, str]] = dataclasses.field(default_factory=list)


def check_scene(scene: Scene, obj: ThinObject, config: PlannerConfig | None = None) -> SceneCheck:
    """Check a scene's robot and hand against its table for objects like ``obj`` (its thickness).

    Args:
        scene: the scene.
        obj: an object on its table (only its thickness matters).
        config: planner parameters; the scene's hand's by default.

    Returns:
        The findings.

    Raises:
        InputError: the robot cannot be loaded, naming the file.
    """
    config = (config or PlannerConfig.for_scene(scene)).resolved(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)  # the report names those meshes itself
        robot = robot_model(scene)
    hand = scene.hand
    findings: list[str] = []
    notes = [f"robot {scene.urdf_path.name}: {robot.dof} planned joints ({', '.join(robot.joint_names)}), "
             f"fingertip {hand.tip_link}, grasp frame on {hand.grasp_link}, contact links {', '.join(hand.contact_links)}",
             _gripper_note(hand), *_mesh_notes(robot)]

    points, reached_points = table_reach_map(scene, obj.thickness, config)
    reach = float(reached_points.mean()) if reached_points.size else 0.0
    line = (f"fingertip: reaches the table top over {100 * reach:.0f}% of the table (5 x 5 grid, pitch beta0 = "
            f"{config.beta0:g}, depth {1000 * 0.5 * (config.dz_min + config.dz_max):.0f} mm, any heading)")
    if reach < MIN_REACH:
        findings.append(line + ": too little for start roots; move the base ([robot] base_pose) or change beta0")
    else:
        notes.append(line)

    world = scene_collision_world(scene)
    if world.always_in_contact:
        notes.append("self-collision: not checked between " + ", ".join(f"{a} and {b}" for a, b in world.always_in_contact)
                     + " (in contact at almost every configuration of the arm: overlapping collision shapes, or a held "
                     "joint value, [robot] fixed_joints or [hand] gripper_joints' open value, that puts them together)")
    offset = base_pose_matrix(hand.grasp_offset)
    mapped = grasp_map(scene, obj, config)
    params = config.to_params()
    graspable_edges, verdicts_by_edge, stretches = 0, [], []
    for edge in range(len(scene.table.vertices)):
        cells = mapped.stretch_count(edge)
        grasps = [mapped.grasp_on(edge, cell) for cell in range(cells)]
        verdicts = [None if grasp is None else
                    _approach_problem(robot, world, grasp, config.grasp_backoff, hand.grasp_link, offset, params)
                    for grasp in grasps]
        stretches += [(*np.asarray(mapped.stretch_grasp(edge, cell))[:2, 3],
                       "none" if verdict is None else "clear" if verdict == "" else "blocked")
                      for cell, verdict in enumerate(verdicts)]
        verdict = _edge_verdict(robot, world, mapped, edge, grasps, verdicts, config, hand.grasp_link, offset, params)
        graspable_edges += verdict.key == ("clear",)
        verdicts_by_edge.append(verdict)
    edges = [_run_line(scene.table.vertices, run) for run in _runs(verdicts_by_edge)]  # a round table has 100 edges
    maps = {"reach_points": points, "reached": reached_points, "stretches": stretches}
    if graspable_edges:
        return SceneCheck(findings + notes + edges, reach >= MIN_REACH, **maps)
    findings += ["no edge admits a side grasp with a clear pre-grasp: no plan can end in a grasp", *edges]
    return SceneCheck(findings + notes, False, **maps)


def _gripper_note(hand) -> str:
    """What closes the hand in execution ([hand] gripper_joints), or that nothing does."""
    if not hand.gripper_joints:
        return "gripper: none ([hand] gripper_joints): execution slides, then has nothing to close"
    joints = ", ".join(f"{name} from {opened:g} to {closed:g}" for name, (opened, closed) in hand.gripper_joints.items())
    return f"gripper: {joints} (held open while planning; its mimic joints follow)"


def _mesh_notes(robot) -> list[str]:
    """How the collision meshes are checked, naming those whose hull is much larger than the mesh."""
    meshes = robot.collision_meshes
    if not meshes:
        return []
    concave = [(link, Path(mesh).name, ratio, exact) for link, mesh, ratio, exact in meshes if ratio > _core.concave_hull_ratio]
    line = f"collision meshes: {len(meshes)}, {len(meshes) - sum(exact for *_, exact in concave)} checked as their convex hulls"
    exact = [f"{link} ({name}, hull {ratio:.2f} x its volume)" for link, name, ratio, is_exact in concave if is_exact]
    hulls = [f"{link} ({name}, {ratio:.2f} x)" for link, name, ratio, is_exact in concave if not is_exact]
    if exact:
        line += f"; as their triangles, the hull filling a concavity of the hand: {', '.join(exact)}"
    if hulls:
        line += f"; arm links whose hull only adds clearance: {', '.join(hulls)}"
    return [line]


def _why_no_grasp(robot, world, mapped, edge: int, cell: int, grasp_link: str, offset: np.ndarray, params) -> str:
    """Why the stretch's H_g (the hand as given) has no grasp: the hand's parts against the table or an
    obstacle, no arm configuration reaching it (within the rotation the hand tolerates, ``params``), or the arm
    in collision there."""
    from .. import _core

    grasp = np.asarray(mapped.stretch_grasp(edge, cell))
    hit = world.rigid_collision(grasp_link, grasp @ np.linalg.inv(offset))
    if hit:
        return f"the hand meets the table or an obstacle ({hit}): a larger grasp_standoff moves it out"
    joints = robot.ik(grasp, rng_seed=0, options=_core.grasp_ik_options(params), link=grasp_link, offset=offset)
    if joints is None:
        return "no arm configuration reaches the grasp frame (out of reach from this mount)"
    pairs = world.collisions(joints, _core.ContactMode.FREE)
    if pairs:
        return "the arm reaching it is in collision (" + ", ".join(f"{a}-{b}" for a, b in pairs[:3]) + ")"
    return "reachable and clear in one configuration, but not liftable by grasp_lift from it"


def _approach_problem(robot, world, grasp: np.ndarray, backoff: float, grasp_link: str, offset: np.ndarray, params) -> str:
    """'' if the grasp configuration ``grasp`` is free of collisions and the pre-grasp ``backoff`` before
    its grasp frame (along the approach axis) is reachable from it (within the rotation the hand tolerates,
    ``params``) and free of collisions; else what is wrong, naming the first colliding pair."""
    from .. import _core

    pairs = world.collisions(grasp, _core.ContactMode.FREE)
    if pairs:
        return f"grasp in collision ({pairs[0][0]}-{pairs[0][1]})"
    pre = np.asarray(robot.frame_pose(grasp, grasp_link, offset))  # the grasp frame, as reached
    pre[:3, 3] -= backoff * pre[:3, 2]
    near = _core.grasp_ik_options(params)
    near.max_attempts = 1  # from the grasp configuration only, as the planner looks for it
    joints = robot.ik(pre, seed=grasp, rng_seed=0, options=near, link=grasp_link, offset=offset)
    if joints is None:
        return "pre-grasp unreachable"
    pairs = world.collisions(joints, _core.ContactMode.FREE)
    return f"pre-grasp in collision ({pairs[0][0]}-{pairs[0][1]})" if pairs else ""


@dataclasses.dataclass(frozen=True)
class _EdgeVerdict:
    """What one table edge admits. ``key`` is what consecutive edges must share to be reported as one range:
    the kind of verdict and, where there is one, the problem and the advice."""

    edge: int
    key: tuple
    cells: int
    reached: int
    clear: int
    blocked: int
    why: str = ""  # for an edge with no grasp: why, at its middle


def _edge_verdict(robot, world, mapped, edge: int, grasps, verdicts, config, grasp_link: str, offset, params) -> _EdgeVerdict:
    """One edge's verdict: no side grasp (and why, at its middle), some clear, or all blocked (by what)."""
    cells, reached = len(grasps), [grasp for grasp in grasps if grasp is not None]
    if not reached:
        why = _why_no_grasp(robot, world, mapped, edge, cells // 2, grasp_link, offset, params)
        return _EdgeVerdict(edge, ("none", why), cells, 0, 0, 0, why)
    problems = Counter(verdict for verdict in verdicts if verdict is not None)
    clear = problems.pop("", 0)
    if clear:
        return _EdgeVerdict(edge, ("clear",), cells, len(reached), clear, 0)
    problem, count = problems.most_common(1)[0]
    if problem.startswith("grasp"):
        return _EdgeVerdict(edge, ("grasp", problem, _grasp_advice(robot, problem)), cells, len(reached), 0, count)
    shorter = next((backoff for backoff in BACKOFFS if backoff < config.grasp_backoff and any(
        _approach_problem(robot, world, grasp, backoff, grasp_link, offset, params) == "" for grasp in reached)), None)
    hint = f"; at {shorter:g} some are clear: try grasp_backoff <= {shorter:g}" if shorter else ""
    return _EdgeVerdict(edge, ("backoff", problem, f"grasp_backoff {config.grasp_backoff:g} leaves the {problem}", hint),
                        cells, len(reached), 0, count)


def _grasp_advice(robot, problem: str) -> str:
    """Advice that fits the colliding pair of a grasp: the hand against the table or an obstacle moves out with
    grasp_standoff; the arm against itself cannot, its mount or the table must move."""
    pair = problem[problem.find("(") + 1:problem.rfind(")")].split("-")
    links = set(robot.link_names)
    if len(pair) == 2 and all(name in links for name in pair):
        return ("the arm meets itself there: the grasp lies at the edge of its workspace from this mount; move the mount "
                "([robot] base_pose) or the table")
    return "a larger grasp_standoff moves the hand out past the edge (or grasp_offset puts the grasp frame inside the hand)"


def _runs(verdicts: list[_EdgeVerdict]) -> list[list[_EdgeVerdict]]:
    """Consecutive edges with the same verdict key, in order."""
    runs: list[list[_EdgeVerdict]] = []
    for verdict in verdicts:
        if runs and runs[-1][-1].key == verdict.key:
            runs[-1].append(verdict)
        else:
            runs.append([verdict])
    return runs


def _run_line(vertices, run: list[_EdgeVerdict]) -> str:
    """One line for a range of edges with one verdict, their counts summed."""
    first, last = run[0].edge, run[-1].edge
    start, end = vertices[first], vertices[(last + 1) % len(vertices)]
    where = f"({start[0]:.2f}, {start[1]:.2f})-({end[0]:.2f}, {end[1]:.2f})"
    name = f"edge {first} {where}" if first == last else f"edges {first}-{last} {where}"
    cells, reached = sum(v.cells for v in run), sum(v.reached for v in run)
    kind = run[0].key[0]
    if kind == "none":
        middle = "at its middle" if first == last else "at the middle of each"
        return f"{name}: no side grasp on any of {'its' if first == last else 'their'} {cells} stretches; {middle}: {run[0].why}"
    line = f"{name}: side grasps on {reached} of {cells} stretches, grasp and pre-grasp clear at {sum(v.clear for v in run)} of them"
    if kind == "clear":
        return line
    blocked = sum(v.blocked for v in run)
    if kind == "grasp":
        return f"{line}: the {run[0].key[1]} at {blocked}: {run[0].key[2]}"
    return f"{line}: {run[0].key[2]} at {blocked}{run[0].key[3]}"
