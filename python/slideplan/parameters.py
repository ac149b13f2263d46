"""The planner's parameters, as the C++ core declares them (``_core.parameters()``, params.cpp).

The registry is the one list of parameters: :class:`~slideplan.plan.config.PlannerConfig`'s fields, the
keys a scene's ``[hand] params`` accepts, the grasp map's key, the paper preset and the table in
docs/parameters.md all come from it. Each entry is a :class:`Parameter`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from . import _core


@dataclass(frozen=True)
class Parameter:
    """One planner parameter.

    Attributes:
        name: the field of PlannerConfig, the [hand] params key and the plan JSON key.
        kind: ``"real"``, ``"int"`` or ``"bool"``.
        unit: ``"m"``, ``"rad"``, ``"rad/m"``, ``"m/rad"`` or ``""``.
        default: the built-in default.
        lower, upper, lower_open, upper_open: the bounds of a valid value.
        paper: the paper's value; None where the paper leaves the parameter open.
        paper_source: where the paper gives the value, or why it gives none.
        hand: whether a scene's ``[hand] params`` may set it.
        grasp_map: whether the grasp map's probes depend on it.
        verify: whether a plan's verification reads it (every plan file carries it).
        doc: what it means.
    """

    name: str
    kind: str
    unit: str
    default: float | int | bool
    lower: float
    upper: float
    lower_open: bool
    upper_open: bool
    paper: float | int | bool | None
    paper_source: str
    hand: bool
    grasp_map: bool
    verify: bool
    doc: str

    @property
    def python_type(self) -> type:
        """``float``, ``int`` or ``bool``."""
        return {"real": float, "int": int, "bool": bool}[self.kind]

    def typed(self, value: float | None):
        """``value`` as this parameter's Python type (None stays None)."""
        return None if value is None else self.python_type(value)

    def bounds(self) -> str:
        """The valid values in words: ``(0, 1.5708] rad``, ``integer >= 1``, ``true or false``."""
        if self.kind == "bool":
            return "true or false"
        if self.kind == "int":
            return f"integer >= {self.lower:g}"
        upper = "inf)" if math.isinf(self.upper) else f"{self.upper:g}{')' if self.upper_open else ']'}"
        return f"{'(' if self.lower_open else '['}{self.lower:g}, {upper}" + (f" {self.unit}" if self.unit else "")


def _load() -> tuple[Parameter, ...]:
    """The core's registry, its values (doubles in C++) as each parameter's own type."""
    raw = [Parameter(**entry) for entry in _core.parameters()]
    return tuple(dataclasses.replace(p, default=p.typed(p.default), paper=p.typed(p.paper)) for p in raw)


REGISTRY: tuple[Parameter, ...] = _load()
"""Every planner parameter, in the core's order."""

BY_NAME: dict[str, Parameter] = {parameter.name: parameter for parameter in REGISTRY}
NAMES: tuple[str, ...] = tuple(BY_NAME)
HAND_NAMES: tuple[str, ...] = tuple(parameter.name for parameter in REGISTRY if parameter.hand)
"""The parameters a scene's ``[hand] params`` may set."""
GRASP_MAP_NAMES: tuple[str, ...] = tuple(parameter.name for parameter in REGISTRY if parameter.grasp_map)
"""The parameters a grasp map's answers depend on (``GraspMap::fits``): its key in memory and on disk."""
VERIFY_NAMES: tuple[str, ...] = tuple(parameter.name for parameter in REGISTRY if parameter.verify)
"""The parameters a plan's verification reads: every plan file must carry them."""
PAPER_VALUES: dict[str, float | int | bool] = {p.name: p.paper for p in REGISTRY if p.paper is not None}
"""What the paper preset fixes: every parameter the paper gives a value for (every departure off)."""


def markdown_table() -> str:
    """docs/parameters.md's table of every parameter, written from the registry."""
    def value(parameter: Parameter, number) -> str:
        if number is None:
            return "open"
        if parameter.kind == "bool":
            return "on" if number else "off"
        return f"{number:g}" + (f" {parameter.unit}" if parameter.unit else "")

    lines = ["| parameter | default | valid | paper preset | [hand] | meaning |", "|---|---|---|---|---|---|"]
    for parameter in REGISTRY:
        paper = f"{value(parameter, parameter.paper)} ({parameter.paper_source})" if parameter.paper is not None \
            else f"default kept: {parameter.paper_source}"
        lines.append(f"| `{parameter.name}` | {value(parameter, parameter.default)} | {parameter.bounds()} | {paper} | "
                     f"{'yes' if parameter.hand else ''} | {parameter.doc} |")
    return "\n".join(lines)
