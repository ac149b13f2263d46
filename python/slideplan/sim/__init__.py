"""Execute a plan in physics: a MuJoCo replay of the whole arm with a compliant finger, then grasp and lift.

:func:`execute` builds a MuJoCo model from the plan alone (its ``robot`` block, table and object
cloud), drives the arm along the plan's trajectory under joint position control, and reports where
the object really ends against Eq. 2's prediction, and whether the side grasp then lifts it.

The model (docs/execution.md gives the numbers and why):

- **Robot**: the plan's URDF (with its ``attach`` fragments), imported by MuJoCo, mounted at
  ``base_pose``. Every body is gravity compensated (as the WAM's own controller does) and each arm
  joint follows its reference through a PD position servo whose gains give every joint the same
  closed-loop bandwidth (:attr:`ExecutionSettings.servo_bandwidth_hz`, critically damped) at the
  start configuration's inertia. The reference is read ahead by kv/kp, which equals velocity
  feed-forward to first order.
- **Finger compliance**: the first contact link gets a passive slide joint (stiffness
  :attr:`ExecutionSettings.finger_stiffness`; by default the stiffness that presses with
  :attr:`ExecutionSettings.press_force`, 4 N, at the middle of the hand's depth band) along the world
  vertical as seen from the finger at the
  planned pitch ``beta0``; a spherical pad whose lowest point is the contact frame ``F`` is the only
  geometry of the contact links that touches anything while sliding. The planned contact depth
  ``z_s - z_F`` is thus the spring's compression, and the normal force is ``k * depth``: 2-6 N for the
  T42's band [1, 3] cm at 200 N/m, 1.1-6.9 N for a rigid finger's [2, 12] mm at 571 N/m.
- **Object**: boxes on a square grid (:attr:`ExecutionSettings.cell_size`), each the bounding box of
  its cell's part of the point cloud's footprint (:func:`object_boxes`), one rigid body of uniform
  density, resting on one small sphere under each box's centre (the only part of it that touches the
  table: :mod:`.contacts`), so table friction is spread over the footprint.
- **Table**: the polygon as a 5 cm thick prism, one convex mesh per triangle of a constrained
  Delaunay triangulation when it is not convex.
- **Grasp**: the hand's own closing joints (``[hand] gripper_joints``, revolute or prismatic; their mimic
  joints follow) are position-servoed from open to closed, every finger reaching the grasp plane
  together, then squeeze on with the grip capped.

Phases: slide along ``trajectory``; settle; follow ``grasp.approach`` (lift, transfer, approach);
close the hand; lift 5 cm; hold 1 s.

The modules: :mod:`.model` builds the MuJoCo model (the robot; :mod:`.world` the table and the object;
:mod:`.contacts` who touches whom and the solver's options), :mod:`.runner` steps it (servoing, the slide,
the grasp), :mod:`.replay` is :func:`execute` (open loop), :mod:`.report` and :mod:`.video` say what
happened; :mod:`slideplan.sim.closed_loop` runs the same model and runner with a camera in the loop,
which :mod:`.calibration` finds from the robot it sees.
"""

from .model import MESH_SUFFIXES, cloud_footprint, object_boxes
from .replay import execute
from .report import EXECUTION_SCHEMA, STAGES, Execution, path_features
from .settings import ExecutionSettings, stress_settings
from .video_frames import write_video

__all__ = ["EXECUTION_SCHEMA", "MESH_SUFFIXES", "STAGES", "Execution", "ExecutionSettings", "cloud_footprint", "execute",
           "object_boxes", "path_features", "stress_settings", "write_video"]
