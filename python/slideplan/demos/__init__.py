"""Demonstrations for robot learning: closed-loop episodes recorded as LeRobotDataset v3.0
(:mod:`~slideplan.demos.generate`, ``slideplan demos``), drawn by :mod:`~slideplan.demos.draw`, framed by
:mod:`~slideplan.demos.frames`, written by :mod:`~slideplan.demos.dataset` (the ``lerobot`` extra)."""
