"""The θ fields of the MuJoCo tasks ("knobs"): what each sets in an ``MjModel``, and its bounds.

Seven kinds of knob, each a plain number:

* :data:`GRAVITY` (m/s²): the signed size of gravity along the (possibly tilted) vertical; with
  no tilt, the z component of ``opt.gravity`` (negative: down), as NS-Gym changes it;
* :data:`TILT` (rad): gravity turned about the y axis, in the x-z plane that the planar tasks
  move in: ``opt.gravity = (x₀ cos α − g sin α, y₀, x₀ sin α + g cos α)`` with ``x₀, y₀`` the
  compiled components, so a positive tilt pulls toward +x (downhill for a walker running forward);
* :data:`MASS` (kg): ``body_mass`` of one body, and (unless the family is built with
  ``scale_inertia=False``) its ``body_inertia`` scaled by the same factor: the same shape made of
  a denser or lighter material, so the inertia stays consistent with the mass;
* :data:`DAMPING`: ``dof_damping`` of one joint (N·m·s/rad on a hinge, N·s/m on a slide joint);
* :data:`FRICTION` (coefficient): the sliding friction of one geom (NS-Gym's ``floor_friction``
  names the floor), **and** every other geom's scaled by the same factor. MuJoCo gives a contact
  the larger of its two geoms' coefficients, so scaling only the floor would not lower the
  friction of a contact with a foot of higher friction (Hopper's foot: 2.0 against the floor's
  1.0); scaling all scales every contact's friction by ``value / default``;
* :data:`FRICTIONLOSS` (N on a slide joint): ``dof_frictionloss`` of one joint, dry (Coulomb)
  friction; the pendulums' ``rail_friction``, since their cart touches nothing (a geom friction
  there, as NS-Gym sets it, has no effect);
* :data:`GEAR` (factor): every actuator's ``actuator_gear`` scaled by the value (motor strength).

Defaults are the compiled models' values (1 for the factors, 0 for the tilt), and every write at
the default gives back the compiled number exactly (a factor of 1.0), so default θ leaves each
model as Gymnasium builds it. Bounds are where each knob acts and the physics stays stable (see
``benchmarks/mujoco_stability.py``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.params import Params, scalar

GRAVITY = "gravity"
"""Kind: the size of gravity along the (tilted) vertical."""
TILT = "tilt"
"""Kind: gravity turned about the y axis."""
MASS = "mass"
"""Kind: one body's mass (and inertia)."""
DAMPING = "damping"
"""Kind: one joint's viscous damping."""
FRICTION = "friction"
"""Kind: one geom's sliding friction, every geom's scaled with it."""
FRICTIONLOSS = "frictionloss"
"""Kind: one joint's dry friction."""
GEAR = "gear"
"""Kind: a factor on every actuator's gear."""
KINDS = (GRAVITY, TILT, MASS, DAMPING, FRICTION, FRICTIONLOSS, GEAR)
"""Every kind of knob."""

_CONSTANTS = (MASS, GEAR)
"""Kinds after whose change MuJoCo's derived constants must be recomputed (``mj_setConst``)."""

_UNITS = {
    GRAVITY: "m/s^2",
    TILT: "rad",
    MASS: "kg",
    DAMPING: "N m s/rad",
    FRICTION: "",
    FRICTIONLOSS: "N",
    GEAR: "",
}


@dataclass(frozen=True)
class Knob:
    """One θ field and where it lives in the model.

    Attributes:
        name: The θ field (NS-Gym's name where NS-Gym has it).
        kind: One of :data:`KINDS`.
        element: The body (mass), joint (damping, frictionloss) or geom (friction) it sets;
            empty for gravity, tilt and gear.
        default: The compiled model's value (exact, so that default θ leaves the model as built).
        low: Lower bound (within it the physics stays stable and the knob acts).
        high: Upper bound.
        unit: Overrides the kind's unit (a damping on a slide joint is in N·s/m).
    """

    name: str
    kind: str
    element: str
    default: float
    low: float
    high: float
    unit: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"Knob.kind={self.kind!r}; allowed: {', '.join(KINDS)}")

    def field(self) -> Any:
        """The dataclass field declaring this parameter, with its bounds and unit."""
        unit = _UNITS[self.kind] if self.unit is None else self.unit
        return scalar(self.default, low=self.low, high=self.high, unit=unit, doc=self.describe())

    def describe(self) -> str:
        """One line saying what the knob sets."""
        return {
            GRAVITY: "gravity along the (tilted) vertical; negative: down",
            TILT: "gravity turned about the y axis; positive pulls toward +x",
            MASS: f"mass of body {self.element!r}",
            DAMPING: f"damping of joint {self.element!r}",
            FRICTION: f"sliding friction of geom {self.element!r}; every geom's scales with it",
            FRICTIONLOSS: f"dry friction of joint {self.element!r}",
            GEAR: "factor on every actuator's gear",
        }[self.kind]


def gravity(default: float = -9.81, low: float = -20.0, high: float = 0.0) -> Knob:
    """The :data:`GRAVITY` knob ``gravity`` (NS-Gym's name)."""
    return Knob("gravity", GRAVITY, "", default, low, high)


def tilt(limit: float = 0.3) -> Knob:
    """The :data:`TILT` knob ``gravity_tilt`` on ``[-limit, limit]`` rad."""
    return Knob("gravity_tilt", TILT, "", 0.0, -limit, limit)


def mass(name: str, element: str, default: float, low: float = 0.2, high: float = 5.0) -> Knob:
    """A :data:`MASS` knob whose bounds are ``low`` and ``high`` times the default."""
    return Knob(name, MASS, element, default, default * low, default * high)


def damping(
    name: str, element: str, default: float, high: float | None = None, unit: str | None = None
) -> Knob:
    """A :data:`DAMPING` knob on ``[0, high]`` (``high``: ten times the default, at least 1)."""
    top = max(default * 10, 1.0) if high is None else high
    return Knob(name, DAMPING, element, default, 0.0, top, unit)


def friction(name: str, element: str, default: float, low: float = 0.1, high: float = 3.0) -> Knob:
    """A :data:`FRICTION` knob whose bounds are ``low`` and ``high`` times the default."""
    return Knob(name, FRICTION, element, default, default * low, default * high)


def frictionloss(name: str, element: str, high: float) -> Knob:
    """A :data:`FRICTIONLOSS` knob on ``[0, high]`` (Gymnasium's joints have none: default 0)."""
    return Knob(name, FRICTIONLOSS, element, 0.0, 0.0, high)


def gear(low: float = 0.5, high: float = 2.0) -> Knob:
    """The :data:`GEAR` knob ``actuator_gain`` (a factor, default 1)."""
    return Knob("actuator_gain", GEAR, "", 1.0, low, high)


def params_class(name: str, knobs: Sequence[Knob], doc: str) -> type[Params]:
    """A frozen :class:`Params` dataclass with one scalar field per knob, in order."""
    fields = [(knob.name, float, knob.field()) for knob in knobs]
    cls = dataclasses.make_dataclass(
        name, fields, bases=(Params,), frozen=True, slots=True, namespace={"__doc__": doc}
    )
    cls.__module__ = "ns_pz.envs.mujoco_tasks"
    return cls


class ModelWriter:
    """Writes knob values into one ``MjModel``, from copies of the compiled values it keeps.

    Args:
        model: The model written to (Gymnasium's, as compiled: its values are the defaults).
        knobs: The θ fields.
        scale_inertia: Scale a body's inertia with its mass.
    """

    def __init__(self, model: Any, knobs: Sequence[Knob], scale_inertia: bool) -> None:
        self.model = model
        self.knobs = tuple(knobs)
        self.scale_inertia = scale_inertia
        self._gravity0 = model.opt.gravity.copy()
        self._inertia0 = model.body_inertia.copy()
        self._friction0 = model.geom_friction[:, 0].copy()
        self._gear0 = model.actuator_gear[:, 0].copy()
        self._gravity_values = [0.0, 0.0]  # (gravity, tilt) in force
        self._gravity_values[0] = float(self._gravity0[2])
        self._ids = [self._element_id(knob) for knob in self.knobs]
        self.needs_constants = tuple(knob.kind in _CONSTANTS for knob in self.knobs)

    def _element_id(self, knob: Knob) -> int:
        model = self.model
        if knob.kind == MASS:
            return int(model.body(knob.element).id)
        if knob.kind in (DAMPING, FRICTIONLOSS):
            return int(model.jnt_dofadr[model.joint(knob.element).id])
        if knob.kind == FRICTION:
            return int(model.geom(knob.element).id)
        return -1

    def write(self, index: int, value: float) -> None:
        """Write the value of knob ``index`` (then ``mj_setConst``: see :attr:`needs_constants`)."""
        knob, model, element = self.knobs[index], self.model, self._ids[index]
        kind = knob.kind
        if kind == MASS:
            model.body_mass[element] = value
            if self.scale_inertia:
                model.body_inertia[element] = self._inertia0[element] * (value / knob.default)
        elif kind == DAMPING:
            model.dof_damping[element] = value
        elif kind == FRICTIONLOSS:
            model.dof_frictionloss[element] = value
        elif kind == FRICTION:
            model.geom_friction[:, 0] = self._friction0 * (value / knob.default)
        elif kind == GEAR:
            model.actuator_gear[:, 0] = self._gear0 * value
        else:  # gravity or tilt: the vector from both
            self._gravity_values[kind == TILT] = value
            self._write_gravity()

    def _write_gravity(self) -> None:
        size, tilt = self._gravity_values
        x0 = self._gravity0[0]
        gravity = self.model.opt.gravity
        if tilt == 0.0:  # exactly the compiled vector at the default
            gravity[0], gravity[2] = x0, size
        else:
            cos, sin = math.cos(tilt), math.sin(tilt)
            gravity[0], gravity[2] = x0 * cos - size * sin, x0 * sin + size * cos

    def read(self, model: Any) -> dict[str, float]:
        """The knob values another model of the same task holds (a model edited by hand).

        Raises:
            ValueError: Its friction or gear is not a common factor of the compiled ones, or its
                gravity has another x or y component than this task's (nothing θ can express).
        """
        values = {}
        for knob, element in zip(self.knobs, self._ids, strict=True):
            values[knob.name] = self._read_one(model, knob, element)
        return values

    def _read_one(self, model: Any, knob: Knob, element: int) -> float:
        kind = knob.kind
        if kind == MASS:
            return float(model.body_mass[element])
        if kind == DAMPING:
            return float(model.dof_damping[element])
        if kind == FRICTIONLOSS:
            return float(model.dof_frictionloss[element])
        if kind == FRICTION:
            value = float(model.geom_friction[element, 0])
            expected = self._friction0 * (value / knob.default)
            return self._common(model.geom_friction[:, 0], expected, knob, value)
        if kind == GEAR:
            value = float(model.actuator_gear[0, 0] / self._gear0[0])
            return self._common(model.actuator_gear[:, 0], self._gear0 * value, knob, value)
        gravity = model.opt.gravity
        if not np.array_equal(gravity[:2], self._gravity0[:2]):
            raise ValueError(
                f"the model's gravity {gravity.tolist()} has another horizontal part than the "
                f"task's {self._gravity0.tolist()}; allowed: only its z component changed"
            )
        return float(gravity[2]) if kind == GRAVITY else 0.0

    @staticmethod
    def _common(actual: np.ndarray, expected: np.ndarray, knob: Knob, value: float) -> float:
        if not np.allclose(actual, expected, rtol=1e-12, atol=0.0):
            raise ValueError(
                f"{knob.name}: the model's values {actual.tolist()} are not the compiled ones "
                f"times one factor ({value!r}); allowed: models whose {knob.kind} was scaled as "
                "a whole"
            )
        return value
