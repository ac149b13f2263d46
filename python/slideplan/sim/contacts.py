"""Who touches whom, and how MuJoCo solves the contacts (the same physics as the model before the feet, faster).

Collision groups (``contype``/``conaffinity``; MuJoCo collides two geoms when the type of either
matches the affinity of the other):

- the **table** touches the robot and the object's feet;
- the **robot** touches the table and the object's shell (never itself);
- the object's **shell** (its boxes: what the pad and the fingers touch) touches the robot only;
- the **clutter** (the scene's obstacles: boxes and cylinders fixed to the world, other thin objects free
  on the table) touches the table, the robot and the object's shell;
- the object's **feet** (one sphere under the centre of each box) touch the table only. A box on the
  table made one to four contacts at its corners (three on average: benchmarks/execute_profile.py);
  its foot makes one, so table friction is still spread over the footprint on the same grid
  (docs/physics-facts.md: "distributed contact") with a third of the constraint rows.

The solver keeps docs/physics-facts.md's settings (elliptic cones, impratio 10, noslip 10 iterations,
1 ms) while the finger slides the object; the noslip pass stops early once it improves less than
``noslip_tolerance``, and is off once the slide is over (``noslip_after_slide``: the pose is measured
by then; the grasp's lift is judged by the fidelity check). Sleeping islands skip the object while it
rests on the table and the arm moves elsewhere (the approach).

Measured (benchmarks/execute_fidelity.py, docs/benchmarks/execution.md): against :data:`LEGACY` on
plans of the Fig. 10 set.

:data:`LEGACY` is the model before the feet (the shell touching the table, no feet, noslip
throughout, no sleeping), kept so that the fidelity check runs both in one process.
"""

from __future__ import annotations

from dataclasses import dataclass

TABLE, ROBOT, SHELL, FEET, CLUTTER = 1, 2, 4, 8, 16


@dataclass(frozen=True)
class Groups:
    """``(contype, conaffinity)`` of each kind of geom."""

    table: tuple[int, int]
    robot: tuple[int, int]
    shell: tuple[int, int]
    feet: tuple[int, int] | None  # None: no feet (the shell rests on the table)
    clutter: tuple[int, int]  # the scene's obstacles: the table, the robot and the object's shell touch them


@dataclass(frozen=True)
class ContactModel:
    """The contact geometry and solver options of the execution model.

    Attributes:
        feet: the object rests on small spheres at its boxes' corners (``"corners"``) or one under each box's
            centre (``"centres"``, :func:`.world.feet`), or on its boxes themselves (None, :data:`LEGACY`).
        feet_cell: the feet stand under the cells of a grid this coarse (m) instead of under each box (None).
        sleep: MuJoCo's sleeping islands (``mjENBL_SLEEP``): a body at rest (the object on the table
            while the arm moves away, the arm holding still) is not stepped until something touches it.
        noslip_iterations, impratio, elliptic: the friction settings of docs/physics-facts.md.
        noslip_after_slide: noslip iterations once the slide is over (approach, close, lift, hold); None:
            ``noslip_iterations`` throughout.
        noslip_tolerance: the noslip pass stops before its iterations when it improves less (MuJoCo's
            default 1e-6).
        tolerance: the constraint solver's tolerance (MuJoCo's default 1e-8).
    """

    feet: str | None = "centres"
    feet_cell: float | None = None
    sleep: bool = True
    noslip_iterations: int = 10
    noslip_after_slide: int | None = 0
    noslip_tolerance: float = 1e-4
    impratio: float = 10.0
    elliptic: bool = True
    tolerance: float = 1e-8

    @property
    def groups(self) -> Groups:
        if self.feet is None:
            return Groups(table=(1, 3 | CLUTTER), robot=(2, 1 | CLUTTER), shell=(1, 3 | CLUTTER), feet=None,
                          clutter=(CLUTTER, 1 | 2))
        return Groups(table=(TABLE, ROBOT | FEET | CLUTTER), robot=(ROBOT, TABLE | SHELL | CLUTTER),
                      shell=(SHELL, ROBOT | CLUTTER), feet=(FEET, TABLE), clutter=(CLUTTER, TABLE | ROBOT | SHELL))

    def apply(self, spec) -> None:
        """Set the solver options on an ``mujoco.MjSpec``."""
        import mujoco

        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if self.elliptic else mujoco.mjtCone.mjCONE_PYRAMIDAL
        spec.option.impratio = self.impratio
        spec.option.noslip_iterations = self.noslip_iterations
        spec.option.tolerance = self.tolerance
        spec.option.noslip_tolerance = self.noslip_tolerance
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        if self.sleep:
            spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)


CURRENT = ContactModel()
LEGACY = ContactModel(feet=None, sleep=False, noslip_after_slide=None, noslip_tolerance=1e-6)
"""The model before the feet (the fidelity check's reference)."""

ACTIVE = [CURRENT]  # what build_model uses unless told: the fidelity check switches it to LEGACY
