"""What a plan becomes for people and controllers.

- :mod:`.export`: a timed plan for a controller (JointTrajectory JSON, CSV);
- :mod:`.pictures`: top-down pictures of plans;
- :mod:`.view3d`: the 3D view in the browser (viser).
"""
