"""The world a plan is made for: the table, the thin objects and the scene files.

- :mod:`.geometry`: the support surface (table top), the area centroid, the overhang and ``Ending``;
- :mod:`.objects`: thin objects, their clouds from outlines or files;
- :mod:`.scenes`: scenes from TOML: table, robot and mount, hand, obstacles.
"""
