"""Planner configuration: :class:`PlannerConfig` (one field per parameter of the registry,
:mod:`slideplan.parameters`), its presets and the core's parameter object."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import field
from typing import Any

import numpy as np

from .. import _core, parameters
from .._fields import as_number, is_number
from ..errors import InputError, require_type
from ..world.scenes import Scene

PLANNERS = ("slideplan", "cbirrt", "cbirrt2")

PRESETS = ("default", "paper")
PARAMETERS = parameters.NAMES
"""The parameters proper (the registry's names): PlannerConfig's fields before ``planner``, ``seed``,
``time_limit_s`` and ``preset``."""


class _ConfigMethods:
    """PlannerConfig's methods; its fields come from the parameter registry (below)."""

    def __post_init__(self) -> None:
        # Types here, by each parameter's registry entry; bounds and the pairs (delta_beta < beta0, dz_min <=
        # dz_max) by the core's validator, a pair once both are set (an unset one may come from the hand).
        given = [name for name in PARAMETERS if getattr(self, name) is not None]
        for name in given:
            _check_field(parameters.BY_NAME[name], getattr(self, name))
        if self.planner not in PLANNERS:
            raise InputError(f"unknown planner {self.planner!r} (expected one of: {', '.join(PLANNERS)})", field="planner")
        if self.preset not in PRESETS:
            raise InputError(f"unknown preset {self.preset!r} (expected one of: {', '.join(PRESETS)})", field="preset")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise InputError(f"expected an integer, got {self.seed!r}", field="seed")
        if not 0 <= self.seed < 2**64:  # the core's uint64
            raise InputError(f"must be in [0, {2**64}), got {self.seed!r}", field="seed")
        as_number(self.time_limit_s, source="", field="time_limit_s", positive=True)
        try:
            self.to_params().validate(given)
        except ValueError as error:
            problem, name = _core_field_message(str(error))
            raise InputError(problem, field=name) from None

    @classmethod
    def for_scene(cls, scene: Scene, preset: str = "default", **overrides) -> PlannerConfig:
        """The config for a scene: built-in defaults, then the hand's ``[hand] params``, then the preset's
        values (``"paper"``: every parameter the paper gives, :data:`slideplan.parameters.PAPER_VALUES`),
        then ``overrides``.

        Args:
            scene: the scene whose hand gives parameter defaults.
            preset: ``"default"`` or ``"paper"``.
            **overrides: any field, e.g. ``seed=3, u_star=0.03``.

        Raises:
            InputError: an unknown field or preset, or a bad value, naming the field (``[hand] params.NAME``
                and the scene's file where the scene's hand gave it).
        """
        require_type(scene, Scene, "scene", "a Scene (from load_scene)")
        unknown = sorted(set(overrides) - {item.name for item in dataclasses.fields(cls)} - {"preset"})
        if unknown:
            raise InputError(f"unknown planner parameter(s) {unknown}", field="param")
        if preset not in PRESETS:
            raise InputError(f"unknown preset {preset!r} (expected one of: {', '.join(PRESETS)})", field="preset")
        published = parameters.PAPER_VALUES if preset == "paper" else {}
        try:
            return cls(**{**scene.hand.params, **published, **overrides, "preset": preset}).resolved(scene)
        except InputError as error:
            if error.field in set(scene.hand.params) - set(published) - set(overrides):
                # The scene's own [hand] params: its file is at fault, not an option or argument.
                raise InputError(error.problem, source=scene.source, field=f"[hand] params.{error.field}") from None
            raise

    def resolved(self, scene: Scene | None = None) -> PlannerConfig:
        """This config with every unset parameter filled: the scene's hand's value, else the built-in one.

        Args:
            scene: the scene whose hand gives defaults (None: built-in defaults only).

        Raises:
            InputError: a value the C++ core's validator refuses, naming the field (a pair names both).
        """
        hand = scene.hand.params if scene is not None else {}
        fills = {name: hand.get(name, parameters.BY_NAME[name].default) for name in PARAMETERS if getattr(self, name) is None}
        return dataclasses.replace(self, **fills) if fills else self

    def sources(self, scene: Scene | None = None) -> dict[str, str]:
        """Where each parameter's value comes from when planning in ``scene``: ``"hand"`` (its
        ``[hand] params``), ``"paper"`` (the paper preset's published value), ``"built-in"``, or
        ``"user"``. A value set explicitly but equal to the hand's, the preset's or the built-in
        default is named by that source."""
        hand = scene.hand.params if scene is not None else {}
        published = parameters.PAPER_VALUES if self.preset == "paper" else {}
        sources = {}
        for name in PARAMETERS:
            value = getattr(self, name)
            if value is None:
                sources[name] = "hand" if name in hand else "built-in"
            elif name in published and value == published[name]:
                sources[name] = "paper"
            elif name in hand and value == hand[name]:
                sources[name] = "hand"
            elif value == parameters.BY_NAME[name].default:
                sources[name] = "built-in"
            else:
                sources[name] = "user"
        return sources

    @classmethod
    def as_published(cls, **overrides) -> PlannerConfig:
        """Algorithm 1 and IsPairValid as published (``preset="paper"``): every parameter the paper gives
        at its value (:data:`slideplan.parameters.PAPER_VALUES`: every departure of
        docs/paper-to-code.md off, ``Delta_beta`` = 0.1 rad, ``Delta_Z`` = [0.5, 2.5] cm, ``N*`` = 100,
        the grasp at ``H_g`` exactly). The fields the paper leaves open (``beta0``, ``u_star``, ...) stay
        unset: ``plan`` takes them from the scene's hand. With ``planner="cbirrt"`` or ``"cbirrt2"``,
        our reading of the baselines (docs/paper-to-code.md).

        Args:
            **overrides: any field, e.g. ``seed=3, planner="cbirrt"``.
        """
        return cls(**{**parameters.PAPER_VALUES, **overrides, "preset": "paper"})

    @property
    def reconfiguration_range(self) -> float:
        """``Delta_Z^* = dz_max - dz_min`` (m), the paper's reconfiguration range."""
        return self.dz_max - self.dz_min

    def with_reconfiguration_range(self, range_m: float) -> PlannerConfig:
        """Return a copy with ``dz_max = dz_min + range_m``.

        Args:
            range_m: reconfiguration range ``Delta_Z^*`` (m), >= 0 (the paper uses 0, 0.005, 0.02).

        Returns:
            The new config.

        Raises:
            InputError: ``range_m`` is negative or not a finite number, or ``dz_min`` is unset
                (call :meth:`resolved` first).
        """
        if self.dz_min is None:
            raise InputError("dz_min is unset: resolve the config for its scene first", field="dz_min")
        if not is_number(range_m) or not math.isfinite(range_m) or range_m < 0:
            raise InputError(f"must be a finite number >= 0 (m), got {range_m!r}", field="reconfiguration_range")
        return dataclasses.replace(self, dz_max=self.dz_min + float(range_m))

    def to_params(self):
        """Build the C++ core's parameter object (not validated: :meth:`_core.PlannerParams.validate`).

        Returns:
            ``_core.PlannerParams`` with every field but ``seed``, ``time_limit_s`` and ``preset``
            (``planner`` becomes ``policy``); unset fields keep the built-in defaults.
        """
        params = _core.PlannerParams()
        for name in PARAMETERS:
            if getattr(self, name) is not None:
                setattr(params, name, getattr(self, name))
        params.policy = self.planner
        return params

    def to_dict(self) -> dict[str, Any]:
        """Return the fields as a plain dict (JSON-ready)."""
        return dataclasses.asdict(self)


def _check_field(parameter: parameters.Parameter, value) -> None:
    """Raise InputError naming ``parameter`` if ``value`` is not of its type (a real: a finite number)."""
    if parameter.kind == "bool":
        if not isinstance(value, (bool, np.bool_)):
            raise InputError(f"expected True or False, got {value!r}", field=parameter.name)
        return
    if parameter.kind == "int":
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(f"expected an integer, got {value!r}", field=parameter.name)
        if not -(2**31) <= value < 2**31:  # the core's int
            raise InputError(f"must be an {parameter.bounds()}, got {value!r}", field=parameter.name)
    elif not is_number(value) or not math.isfinite(value):
        raise InputError(f"expected a finite number, got {value!r}", field=parameter.name)


def _config_doc() -> str:
    lines = [
        "Planner parameters, one field per entry of the parameter registry (:mod:`slideplan.parameters`).",
        "",
        "A parameter left unset (None) is filled when planning: from the scene's hand (its ``[hand]",
        "params``), else the built-in default (:meth:`resolved`); the plan JSON records where each value",
        "came from (``params.sources``: ``built-in``, ``hand``, ``paper`` or ``user``). So",
        "``PlannerConfig(seed=1)`` plans with the hand's contact depth band and grasp standoff.",
        "",
        "Attributes:",
    ]
    for p in parameters.REGISTRY:
        paper = f"paper: {p.paper!r}" if p.paper is not None else "paper: open"
        lines.append(f"    {p.name}: {p.doc} ({p.bounds()}; default {p.default!r}; {paper}.)")
    lines += [
        "    planner: ``\"slideplan\"`` (Algorithm 1), ``\"cbirrt\"`` or ``\"cbirrt2\"`` (our reading of the",
        "        baselines of V-6, docs/paper-to-code.md).",
        "    seed: random seed; the same seed gives the same plan.",
        "    time_limit_s: planning time budget (s); a plan the limit cuts short is not returned.",
        "    preset: ``\"default\"`` (this project's) or ``\"paper\"`` (:meth:`as_published`), recorded in the plan.",
        "",
        "Raises:",
        "    InputError: on construction, naming the field: a value of the wrong type or out of its bounds,",
        "        an unknown planner or preset, a time limit that is not a positive number; once every",
        "        parameter is set (:meth:`resolved`), an inconsistent pair (``delta_beta < beta0``,",
        "        ``dz_min <= dz_max``), naming both.",
    ]
    return "\n".join(lines)


PlannerConfig = dataclasses.make_dataclass(
    "PlannerConfig",
    [(p.name, p.python_type | None, field(default=None)) for p in parameters.REGISTRY]
    + [("planner", str, field(default="slideplan")), ("seed", int, field(default=0)),
       ("time_limit_s", float, field(default=60.0)), ("preset", str, field(default="default"))],
    bases=(_ConfigMethods,), frozen=True, namespace={"__module__": __name__, "__doc__": _config_doc()},
)


def _core_field_message(message: str) -> tuple[str, str]:
    """``(problem, field)`` of the core validator's "planner parameter NAME must ..." message."""
    prefix = "planner parameter "
    if not message.startswith(prefix):
        return message, "param"
    name, _, problem = message[len(prefix):].partition(" ")
    return problem, name
