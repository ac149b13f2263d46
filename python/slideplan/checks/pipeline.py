"""The one way from an object to a plan a robot may run: plan (Algorithm 1), verify, and mark a solved
plan the verifier rejects ``invalid``; for a perceived object, first raise the margins measured from
perceived edges by how far those edges may be off. The CLI, the ROS node, the closed loop and the
experiments all plan through :func:`plan_checked`, so they cannot drift apart."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..world.objects import ThinObject
from ..plan.config import PlannerConfig
from ..plan.planner import plan
from ..plan.result import PlanResult
from ..world.scenes import Scene
from ..plan.timing import TimingOptions
from .verify import Verification, verify


@dataclass(frozen=True)
class Checked:
    """A plan and its verification.

    Attributes:
        result: the plan; ``status`` is ``"invalid"`` when it was solved and the verifier rejected it.
        verification: the verifier's answer for a solved plan, None for a plan not solved.
    """

    result: PlanResult
    verification: Verification | None

    @property
    def ok(self) -> bool:
        """True for a solved plan that passed the verifier."""
        return self.result.solved


def for_perceived(config: PlannerConfig, edge_uncertainty: float) -> PlannerConfig:
    """The config for an object and table seen by a camera: the plan must hold on the true geometry, so
    the margins measured between perceived edges (``u_star``, ``grasp_standoff``) grow by how far those
    edges may be off (``Perception.edge_uncertainty``, m). ``config`` must be resolved."""
    return dataclasses.replace(config, u_star=config.u_star + edge_uncertainty,
                               grasp_standoff=config.grasp_standoff + edge_uncertainty)


def plan_checked(scene: Scene, obj: ThinObject, config: PlannerConfig | None = None, timing: TimingOptions | None = None,
                 *, start_config=None) -> Checked:
    """Plan (:func:`slideplan.plan`), then verify a solved plan (:func:`slideplan.verify`) and mark it
    ``invalid`` if it fails.

    Args:
        scene, obj, config, timing, start_config: as :func:`slideplan.plan`.

    Raises:
        InputError: as :func:`slideplan.plan`.
    """
    result = plan(scene, obj, config, timing, start_config=start_config)
    if not result.solved:
        return Checked(result, None)
    verification = verify(result, given_start=start_config is not None)
    if not verification.ok:
        result = dataclasses.replace(result, status="invalid")
    return Checked(result, verification)
