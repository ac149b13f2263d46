"""Perception: from a depth camera's cloud to a table and the objects on it, and the object tracked while
it slides. No physics here; the simulated camera's frames come from :mod:`slideplan.sim.rendering`.

- :mod:`.camera`: a pinhole depth camera, its pose and pixels, a depth image back-projected;
- :mod:`.framing`: where a camera must stand to keep points in view;
- :mod:`.planes`: the table plane of a scene cloud (RANSAC) and the grid cell it sets;
- :mod:`.tabletop`: :func:`perceive`, a scene cloud to the table top and the objects on it (:class:`Perception`);
- :mod:`.registration`: a known outline registered to a perceived object's points;
- :mod:`.files`: a perception written as a scene file and object clouds;
- :mod:`.tracking`: the sliding object tracked in depth frames;
- :mod:`.calibration`: the camera's mounting error found from the robot it sees.
"""

from .._moved import forwarding

__getattr__ = forwarding(__name__, __path__, "slideplan.perception.tabletop", api=("perceive", "Perception"))
__all__ = ["Perception", "perceive"]
