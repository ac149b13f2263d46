"""The closed loop's decisions, for any arm and camera: no physics here, so the simulated run
(:mod:`slideplan.sim.closed_loop`) and the ROS node (:mod:`slideplan.ros.execution`) share them.

- :mod:`.bounds`: bounds on a run: no progress, re-plans, slide time;
- :mod:`.watch`: what the loop makes of the camera's frames: looks, drifts, the settled look, re-plans;
- :mod:`.decisions`: :class:`SlideLoop`, the decisions over a slide: switch, stop and look, slide on,
  grasp, new contact.
"""

from .._moved import forwarding

__getattr__ = forwarding(__name__, __path__, "slideplan.loop.decisions", api=("SlideLoop", "Arm", "Stop"))
__all__ = ["Arm", "SlideLoop", "Stop"]
