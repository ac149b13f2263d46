"""Interactive 3D view of a plan in the browser (viser), and recordings that play without us.

The scene: the robot (the plan's URDF at its ``base_pose``, visual meshes if the URDF has any,
else its collision primitives), the table as a prism, the object (its top-surface cloud, meshed)
moving with the fingertip by Eq. 2, its final pose (translucent) with the overhanging points in
red, the fingertip path, the grasp frame and the path of the grasp frame along the approach. A
time slider (with play) scrubs the timed slide, then the approach (:mod:`slideplan.plan.timing`);
"show arm" hides the arm, which stands over the object while it slides.

Why viser: it serves a three.js client from Python with no build step, loads URDFs (through
yourdfpy), has GUI sliders, and serializes a scene with its animation to one standalone HTML file.

:func:`open_view` serves a plan; :func:`record` writes the animation to a ``.html`` file (self-
contained: open it in any browser, no server and no Python needed) or a ``.viser`` file (viser's
recording format, for viser's own player). The view needs the ``view`` extra (viser, yourdfpy).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
import socket
import threading
import time
from pathlib import Path

import numpy as np

from .._files import write_bytes, write_text
from ..errors import InputError
from ..perception.framing import frame_points, view_direction
from ..plan.result import PlanResult
from ..transforms import move_planar, quaternion_wxyz, row_to_pose
from ..transforms import planar_motion

# Colours (RGB 0-255) with distinct hues, so that a screenshot can tell the parts apart (tests do).
from ..checks.verify import require_motion
ROBOT_COLOR = (40, 160, 170)
TABLE_COLOR = (200, 150, 80)
OBJECT_COLOR = (220, 40, 160)
OVERHANG_COLOR = (230, 30, 30)
TIP_PATH_COLOR = (30, 130, 60)
APPROACH_PATH_COLOR = (120, 80, 200)
TABLE_THICKNESS_M = 0.04  # the table is drawn as a prism this thick under its top
FPS = 30  # play rate (slider steps per second of plan time)
CAMERA_ELEVATION_RAD = math.radians(60.0)  # the initial view's height above the table's plane
VIEW_ASPECT = 4 / 3  # framed for a window at least this wide (width / height)
RECORD_FPS = 10  # recording frames per second of plan time: the page replays them in software rendering too


@dataclasses.dataclass
class Segment:
    """One timed segment of the timeline.

    Attributes:
        name: ``"slide"`` or ``"approach"``.
        start: global time at which it starts (s).
        times: (M,) time from its start (s).
        configs: (M, dof) joint configurations.
    """

    name: str
    start: float
    times: np.ndarray
    configs: np.ndarray


def object_motions(result: PlanResult) -> np.ndarray:
    """The object's planar motion at every slide waypoint (Eq. 2).

    At waypoint ``k`` the object has moved as the contact frame has from waypoint 0 to ``k``:
    the planar motion (x, y, yaw of ``X_F``) of :func:`slideplan.transforms.planar_motion`.

    Args:
        result: a plan with fingertip poses (none for an unsolved plan).

    Returns:
        (M, 3) rows ``(x, y, yaw)``: ``p' = R(yaw) p + (x, y)``; yaw unwrapped along the path.
    """
    poses = [row_to_pose(row) for row in np.asarray(result.fingertip_poses)]
    motions = np.array([planar_motion(poses[0], pose) for pose in poses]).reshape(-1, 3)
    motions[:, 2] = np.unwrap(motions[:, 2])
    return motions


def timeline(result: PlanResult) -> list[Segment]:
    """The timed segments of a solved plan, one after the other (empty when not solved).

    Args:
        result: the plan; it must carry ``timing`` when solved.

    Returns:
        The slide, then the approach (left out when it has no waypoint).
    """
    if not result.solved:
        return []
    segments, start = [], 0.0
    for name, key, configs in (("slide", "trajectory", result.trajectory), ("approach", "approach", result.grasp["approach"])):
        times = np.asarray(result.timing[key]["time_from_start"], dtype=float)
        if len(times):
            segments.append(Segment(name, start, times, np.asarray(configs, dtype=float)))
            start += float(times[-1])
    return segments


def _interpolate(times: np.ndarray, values: np.ndarray, t: float) -> np.ndarray:
    """Linear interpolation of rows of ``values`` at time ``t`` (clamped to the ends)."""
    index = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
    if index == len(times) - 1:
        return values[index]
    fraction = (t - times[index]) / (times[index + 1] - times[index])
    return values[index] + fraction * (values[index + 1] - values[index])


def object_mesh(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate an object's top-surface cloud, keeping concave outlines concave.

    Delaunay triangles with an edge longer than three point spacings (those bridging a notch
    or a hole) are dropped: a simple alpha shape.

    Args:
        points: (N, 3) cloud, N >= 3.

    Returns:
        ``(vertices (N, 3), faces (F, 3))``.
    """
    from scipy.spatial import Delaunay, QhullError

    try:
        faces = Delaunay(points[:, :2]).simplices
    except QhullError:  # degenerate (collinear) cloud: draw no surface, the points still show
        return points, np.zeros((0, 3), dtype=int)
    corners = points[faces][:, :, :2]
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    spacing = np.median(edges.min(axis=1))
    return points, faces[edges.max(axis=1) <= 3.0 * spacing]


def _planar(motion) -> tuple[np.ndarray, np.ndarray]:
    """(wxyz, position) of a planar motion ``(x, y, yaw)``."""
    x, y, yaw = (float(value) for value in motion)
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]), np.array([x, y, 0.0])


class PlanView:
    """A plan drawn into a viser server, with a timeline.

    Args:
        server: the viser server to draw into.
        result: the plan; a solved plan without timing is timed with the default limits.

    Attributes:
        server: the viser server.
        segments: the timed segments (:func:`timeline`).
        duration: total time of the plan (s), 0 when not solved.
        slider: the time slider (None when not solved).
        play: the "play" checkbox (None when not solved): while on, the slider advances in real time.
        url: ``http://HOST:PORT`` where the server listens.

    Raises:
        InputError: the URDF cannot be loaded, or the plan cannot be timed.
    """

    def __init__(self, server, result: PlanResult) -> None:
        if result.solved and result.timing is None:
            from ..plan.timing import parameterize

            result = dataclasses.replace(result, timing=parameterize(result))
        self.server = server
        self.result = result
        self.segments = timeline(result)
        self.duration = self.segments[-1].start + float(self.segments[-1].times[-1]) if self.segments else 0.0
        self._motions = object_motions(result) if result.solved else np.zeros((0, 3))
        self._lock = threading.Lock()
        self._playing = threading.Event()
        server.scene.set_up_direction("+z")
        self._set_camera()
        # The panel first: a browser receives the scene in order, and the robot's meshes take seconds.
        self._add_gui()
        self._add_static_scene()
        self._add_robot()
        self._connect_gui()
        self.show(0.0)

    @property
    def url(self) -> str:
        """Where the view is served."""
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    def _set_camera(self) -> None:
        """Frame what a user checks: the whole table, the object at its start and final poses, the
        fingertip path and the grasp. Seen from beyond the object, three-quarter to the arm and from
        above, steep enough that the wrist over the object does not hide it."""
        result = self.result
        height = float(result.table["height"])
        polygon = np.asarray(result.table["polygon"], dtype=float)
        footprint = np.asarray(result.object["points"], dtype=float)[:, :2]
        points = [np.column_stack([polygon, np.full(len(polygon), height)])]
        target = np.asarray(result.object["com_xy"], dtype=float)
        if len(self._motions):
            target = move_planar(target, self._motions[-1])
            final = move_planar(footprint, self._motions[-1])
            points += [np.column_stack([final, np.full(len(final), height)]),
                       np.asarray(result.fingertip_poses, dtype=float)[:, :3], row_to_pose(result.grasp["pose"])[None, :3, 3]]
        points.append(np.column_stack([footprint, np.full(len(footprint), height)]))
        base = np.asarray(result.robot["base_pose"], dtype=float)[:2, 3]
        away = target - base
        heading = math.atan2(away[1], away[0]) + 0.7  # a three-quarter view rather than along the arm
        camera = self.server.initial_camera
        look_at, position = frame_points(np.concatenate(points), view_direction(heading, CAMERA_ELEVATION_RAD),
                                         camera.fov, VIEW_ASPECT, margin=1.3)
        camera.look_at, camera.position = look_at, position

    # -- scene --------------------------------------------------------------------------------

    def _add_static_scene(self) -> None:
        import shapely
        import trimesh

        scene, result = self.server.scene, self.result
        polygon = np.asarray(result.table["polygon"], dtype=float)
        height = float(result.table["height"])
        prism = trimesh.creation.extrude_polygon(shapely.Polygon(polygon), TABLE_THICKNESS_M)
        scene.add_mesh_simple("/table", prism.vertices, prism.faces, color=TABLE_COLOR,
                              position=(0.0, 0.0, height - TABLE_THICKNESS_M))
        for index, box in enumerate(result.obstacles):
            cube = trimesh.creation.box(extents=np.asarray(box["size"], dtype=float))
            scene.add_mesh_simple(f"/obstacles/{index}", cube.vertices, cube.faces, color=(150, 150, 150),
                                  wxyz=_planar((0, 0, box["yaw"]))[0], position=np.asarray(box["center"], dtype=float))
        points = np.asarray(result.object["points"], dtype=float)
        vertices, faces = object_mesh(points)
        self._object = scene.add_frame("/object", show_axes=False)
        scene.add_mesh_simple("/object/surface", vertices, faces, color=OBJECT_COLOR, side="double")
        scene.add_point_cloud("/object/points", points, OBJECT_COLOR, point_size=0.003)
        center = np.append(polygon.mean(axis=0), height)
        if not result.solved:
            scene.add_label("/status", f"not solved ({result.status})", position=center + (0, 0, 0.3),
                            anchor="center-center", font_screen_scale=2.0)
            return
        final_wxyz, final_position = _planar(self._motions[-1])
        scene.add_frame("/final_object", show_axes=False, wxyz=final_wxyz, position=final_position)
        scene.add_mesh_simple("/final_object/surface", vertices, faces, color=OBJECT_COLOR, opacity=0.3, side="double")
        self._add_overhang(points, polygon)
        tips = np.asarray(result.fingertip_poses, dtype=float)[:, :3]
        if len(tips) > 1:
            scene.add_line_segments("/fingertip_path", np.stack([tips[:-1], tips[1:]], axis=1), TIP_PATH_COLOR,
                                    thickness=0.003)
        grasp = row_to_pose(result.grasp["pose"])
        scene.add_frame("/grasp", axes_length=0.06, axes_radius=0.003, wxyz=quaternion_wxyz(grasp), position=grasp[:3, 3])
        scene.add_label("/grasp/label", "grasp", position=(0.0, 0.0, 0.07), anchor="bottom-left")

    def _add_overhang(self, points: np.ndarray, polygon: np.ndarray) -> None:
        """The object's points outside the table at its final pose, in red (in the final pose's frame)."""
        import shapely

        moved = move_planar(points[:, :2], self._motions[-1])
        outside = ~shapely.contains_xy(shapely.Polygon(polygon), moved[:, 0], moved[:, 1])
        if outside.any():
            scene = self.server.scene
            scene.add_point_cloud("/final_object/overhang", points[outside] + (0, 0, 0.001), OVERHANG_COLOR, point_size=0.004)
            # On the overhanging part's top, where the eye looks for it.
            scene.add_label("/final_object/label", f"overhang {100 * self.result.overhang_m:.1f} cm",
                            position=points[outside].mean(axis=0) + (0, 0, 0.005), anchor="bottom-left")

    def _add_robot(self) -> None:
        import yourdfpy
        from viser.extras import ViserUrdf

        from .. import _core
        from ..plan.robot import merge_urdf, search_dirs

        result, scene = self.result, self.server.scene
        path = Path(result.robot["urdf"])
        package_dirs = search_dirs(result.robot)

        def mesh_file(fname: str) -> str:
            # The planner's resolver: package:// through the plan's package_dirs, else next to the URDF.
            return _core.resolve_uri(fname, str(path.parent), package_dirs)

        xml = merge_urdf(path, [Path(fragment) for fragment in result.robot["attach"]])  # names the file that fails
        try:
            urdf = yourdfpy.URDF.load(
                io.StringIO(xml), build_scene_graph=True, build_collision_scene_graph=True, load_meshes=True,
                load_collision_meshes=True, filename_handler=mesh_file,
            )
        except Exception as error:  # yourdfpy raises anything from OSError to lxml and trimesh errors
            raise InputError(f"cannot load the robot ({type(error).__name__}: {error})", source=str(path), field="robot.urdf") from None
        base = np.asarray(result.robot["base_pose"], dtype=float)
        self._robot_frame = scene.add_frame("/robot", show_axes=False, wxyz=quaternion_wxyz(base), position=base[:3, 3])
        visual = urdf.scene is not None and len(urdf.scene.geometry) > 0  # the bundled robot has primitives only
        self._urdf = urdf
        self._robot = ViserUrdf(self.server, urdf, root_node_name="/robot", load_meshes=visual, load_collision_meshes=not visual,
                                collision_mesh_color_override=ROBOT_COLOR)
        names = list(self._robot.get_actuated_joint_names())
        # Joints of the URDF that the plan does not move stay at their held value (fixed_joints) or 0.
        self._joint_slots = [names.index(name) if name in names else None for name in result.joint_names]
        self._home = np.array([float(result.robot["fixed_joints"].get(name, 0.0)) for name in names])
        tip = scene.add_frame("/robot/fingertip", axes_length=0.04, axes_radius=0.002)
        self._tip = tip
        if result.solved and len(result.grasp["approach"]):
            grasp_offset = np.asarray(result.robot["grasp_offset"], dtype=float)
            grasp_path = np.array([(self._link_pose(config, result.robot["grasp_link"]) @ grasp_offset)[:3, 3]
                                   for config in result.grasp["approach"]])
            world = grasp_path @ base[:3, :3].T + base[:3, 3]
            scene.add_line_segments("/approach_path", np.stack([world[:-1], world[1:]], axis=1), APPROACH_PATH_COLOR,
                                    thickness=0.003)

    def _urdf_config(self, config: np.ndarray) -> np.ndarray:
        full = self._home.copy()
        for value, slot in zip(config, self._joint_slots):
            if slot is not None:
                full[slot] = value
        return full

    def _link_pose(self, config: np.ndarray, link: str) -> np.ndarray:
        """A link's pose in the robot's base frame at a plan configuration (yourdfpy kinematics)."""
        self._urdf.update_cfg(self._urdf_config(config))
        return self._urdf.get_transform(link, self._urdf.base_link, collision_geometry=True)

    # -- timeline ------------------------------------------------------------------------------

    def _add_gui(self) -> None:
        gui, result = self.server.gui, self.result
        # The arm stands over the object while it slides: hiding it shows the object's motion.
        self._arm = gui.add_checkbox("show arm", initial_value=True)
        if not result.solved:
            gui.add_markdown(f"**not solved** (status `{result.status}`): the scene only")
            self.slider = self.play = None
            return
        times = " + ".join(f"{segment.name} {segment.times[-1]:.1f} s" for segment in self.segments)
        gui.add_markdown(f"**solved**: overhang {100 * result.overhang_m:.1f} cm; {times}")
        self.slider = gui.add_slider("time (s)", min=0.0, max=round(self.duration, 2), step=0.01, initial_value=0.0)
        self.play = gui.add_checkbox("play", initial_value=False)

    def _connect_gui(self) -> None:
        """Make the panel's controls act, once the robot they move is loaded."""
        arm, play = self._arm, self.play
        arm.on_update(lambda _: setattr(self._robot_frame, "visible", arm.value))
        if play is None:
            return
        self.slider.on_update(lambda _: self.show(self.slider.value))
        player: list[threading.Thread] = []

        def toggle(_) -> None:
            if not play.value:
                self._playing.clear()
            elif not (player and player[-1].is_alive()):  # one player thread at a time
                self._playing.set()
                player[:] = [threading.Thread(target=self._play, daemon=True)]
                player[0].start()
            else:
                self._playing.set()

        play.on_update(toggle)

    def _play(self) -> None:
        """Advance the slider in real time (by the clock, however long drawing takes) while "play"
        is on, looping at the end."""
        start_clock, start_value = time.monotonic(), self.slider.value
        while self._playing.is_set():
            value = start_value + time.monotonic() - start_clock
            if value > self.slider.max:
                start_clock, start_value, value = time.monotonic(), 0.0, 0.0
            self.slider.value = round(value, 2)
            time.sleep(1.0 / FPS)

    def show(self, t: float) -> None:
        """Put the robot, the fingertip frame and the object where they are at time ``t``.

        Args:
            t: time since the start of the slide (s); clamped to the plan. An unsolved plan
                shows the robot at its zero configuration.
        """
        with self._lock:
            if not self.segments:
                config, motion = np.zeros(len(self.result.joint_names)), np.zeros(3)
            else:
                t = min(max(float(t), 0.0), self.duration)
                segment = next((s for s in self.segments if t <= s.start + s.times[-1]), self.segments[-1])
                config = _interpolate(segment.times, segment.configs, t - segment.start)
                if segment.name == "slide":
                    motion = _interpolate(segment.times, self._motions, t)
                else:
                    motion = self._motions[-1]
            self._robot.update_cfg(self._urdf_config(config))
            tip = self._urdf.get_transform(self.result.robot["tip_link"], self._urdf.base_link, collision_geometry=True) @ \
                np.asarray(self.result.robot["tip_offset"], dtype=float)
            self._tip.wxyz, self._tip.position = quaternion_wxyz(tip), tip[:3, 3]
            self._object.wxyz, self._object.position = _planar(motion)


def _server(host: str, port: int):
    """A viser server on ``host``, at ``port`` or the next free port; its banner is not printed
    (the command line prints one line with the address instead).

    Raises:
        InputError: nothing can listen on ``host`` (viser would try port after port forever).
    """
    import viser

    try:
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
            probe.bind((host, 0))
    except (OSError, UnicodeError) as error:
        raise InputError(f"cannot listen on {host!r} ({error})", field="--host") from None
    with contextlib.redirect_stdout(io.StringIO()):
        return viser.ViserServer(host=host, port=port, verbose=False)


def open_view(result: PlanResult, host: str = "127.0.0.1", port: int = 8080) -> PlanView:
    """Serve a plan's 3D view.

    Args:
        result: the plan (solved or not).
        host: interface to listen on (default: this machine only).
        port: the port to try first; if it is taken, the next free one is used
            (``view.server.get_port()`` tells which).

    Returns:
        The view; ``view.server.stop()`` ends it.

    Raises:
        InputError: nothing can listen on ``host``, the robot cannot be loaded, the plan's motion cannot
            be run (:func:`slideplan.checks.verify.require_motion`) or it cannot be timed.
    """
    require_motion(result)
    server = _server(host, port)
    try:
        return PlanView(server, result)
    except BaseException:
        server.stop()
        raise


def record(result: PlanResult, out: Path) -> Path:
    """Write the view, animated over the whole plan, to a file that opens without slideplan.

    Frames are recorded at ``RECORD_FPS`` per second of plan time, with plain lighting (no environment
    map), so that a browser without a GPU shows the first frame within seconds.

    Args:
        result: the plan.
        out: ``*.viser`` for viser's recording format, anything else (e.g. ``*.html``) for one
            self-contained HTML page (open it in a browser; it plays the recording).

    Returns:
        ``out``.

    Raises:
        InputError: the robot cannot be loaded or the plan cannot be timed.
        OSError: the file cannot be written.
    """
    view = open_view(result, "127.0.0.1", 0)  # port 0: any free port, nobody needs to connect
    # No image-based lighting: a browser without a GPU spends most of the first frame prefiltering
    # the environment map (Panda plan, software WebGL: 14 s to the first frame with it, 3.6 s without).
    view.server.scene.configure_environment_map(hdri=None)
    try:
        serializer = view.server.get_scene_serializer()
        frames = max(1, math.ceil(view.duration * RECORD_FPS))
        for frame in range(frames + 1):
            view.show(frame / RECORD_FPS)
            serializer.insert_sleep(1.0 / RECORD_FPS)
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix == ".viser":
            write_bytes(out, serializer.serialize())
        else:
            write_text(out, serializer.as_html())
    finally:
        view.server.stop()
    return out
