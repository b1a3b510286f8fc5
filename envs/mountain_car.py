"""MountainCar and MountainCarContinuous with gravity and engine strength as θ.

Same physics as Gymnasium's ``MountainCar-v0`` and ``MountainCarContinuous-v0`` (velocity
clipped to ±0.07, position clipped to [-1.2, 0.6], an inelastic left wall, start position
uniform in [-0.6, -0.4] at rest), written as functions of θ. Gymnasium's discrete env reads
``gravity`` and ``force`` from attributes; its continuous env reads ``power`` from an attribute
but hard-codes the gravity 0.0025 in ``step``: here both are θ fields (``gravity`` defaults to
that constant), so nature can change gravity in either.

Bounds: ``gravity``, ``force`` and ``power`` lie in [0, 0.1]. Zero is allowed (no slope, a dead
engine); a negative gravity would turn the valley into a hill and a negative engine would swap
the actions, which are different tasks, so they are refused. Past 0.07 any of them exceeds the
velocity clip in one step, so larger values would add nothing.

The continuous env stores its state as float32 after every step and computes partly in float32
(NumPy 2's rules for a float32 action or state meeting Python floats); this family reproduces
that arithmetic on Python floats (:func:`~ns_pz.envs.continuous.f32`), so its trajectories
equal Gymnasium's bit for bit for float32 actions, the dtype of its action space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces
from ns_pz.envs.continuous import check_box_action, f32

from ns_pz.family import EnvFamily
from ns_pz.params import Params, scalar
from ns_pz.states import check_real_state

if TYPE_CHECKING:
    from ns_pz.envs.rendering import GymnasiumPainter

MIN_POSITION = -1.2
MAX_POSITION = 0.6
MAX_SPEED = 0.07
GOAL_POSITION = 0.5
"""Goal of the discrete env."""
CONTINUOUS_GOAL_POSITION = 0.45
"""Goal of the continuous env."""

MIN_POSITION_32 = f32(MIN_POSITION)
"""The left wall as NumPy sees it beside a float32 value (its float32 rounding)."""
MAX_POSITION_32 = f32(MAX_POSITION)
"""The right bound beside a float32 value."""
MAX_SPEED_32 = f32(MAX_SPEED)
"""The speed limit beside a float32 value."""
GOAL_32 = f32(CONTINUOUS_GOAL_POSITION)
"""The continuous env's goal beside a float32 value."""

_STATE_FIELDS = ("position", "velocity")
_STATE_BOUNDS = ((MIN_POSITION, MAX_POSITION), (-MAX_SPEED, MAX_SPEED))

State = tuple[float, float]
ContinuousState = tuple[float, float, bool]
"""``(position, velocity, stored_as_float32)``: Gymnasium's start state is float64, every later
state float32, and the arithmetic of a step depends on which (see the module docstring)."""


def _check_goal_velocity(goal_velocity: Any) -> float:
    if isinstance(goal_velocity, bool) or not isinstance(
        goal_velocity, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"goal_velocity={goal_velocity!r} must be a real number")
    value = float(goal_velocity)
    if math.isnan(value):
        raise ValueError(f"goal_velocity={goal_velocity!r} must not be NaN")
    return value


@dataclass(frozen=True, slots=True)
class MountainCarParams(Params):
    """Physical constants of the discrete MountainCar (defaults: Gymnasium's)."""

    gravity: float = scalar(
        0.0025, low=0.0, high=0.1, unit="velocity/step", doc="slope pull: -gravity*cos(3x)"
    )
    force: float = scalar(
        0.001, low=0.0, high=0.1, unit="velocity/step", doc="velocity change of one push"
    )


@dataclass(frozen=True, slots=True)
class MountainCarContinuousParams(Params):
    """Physical constants of MountainCarContinuous (defaults: Gymnasium's)."""

    gravity: float = scalar(
        0.0025,
        low=0.0,
        high=0.1,
        unit="velocity/step",
        doc="slope pull: -gravity*cos(3x) (a constant in Gymnasium's step)",
    )
    power: float = scalar(
        0.0015, low=0.0, high=0.1, unit="velocity/step", doc="velocity change of a full push"
    )


class MountainCarFamily(EnvFamily):
    """MountainCar dynamics as a function of :class:`MountainCarParams`.

    Actions: 0 push left, 1 no push, 2 push right. Reward -1 per step; terminal once the car is
    at ``x >= 0.5`` with velocity ``>= goal_velocity``.

    Args:
        goal_velocity: Velocity the car must have at the goal (Gymnasium's constructor argument).

    Raises:
        ValueError: ``goal_velocity`` is not a real number or is NaN.
    """

    params_cls = MountainCarParams
    render_modes = ("human", "rgb_array")
    render_fps = 30
    deterministic_step = True

    def __init__(self, goal_velocity: float = 0.0) -> None:
        self.goal_velocity = _check_goal_velocity(goal_velocity)
        self.observation_space = spaces.Box(
            np.array([MIN_POSITION, -MAX_SPEED], np.float32),
            np.array([MAX_POSITION, MAX_SPEED], np.float32),
            dtype=np.float32,
        )
        self.action_space = spaces.Discrete(3)

    def initial_state(self, rng: np.random.Generator) -> State:
        """Position uniform in [-0.6, -0.4], at rest (one draw, as Gymnasium)."""
        return (float(rng.uniform(low=-0.6, high=-0.4)), 0.0)

    def step(  # type: ignore[override]  # θ is this family's own parameter set
        self,
        state: State,
        action: int,
        theta: MountainCarParams,
        rng: np.random.Generator,
    ) -> tuple[State, float, bool]:
        """One step of Gymnasium's update (same operations in the same order)."""
        position, velocity = state
        velocity = velocity + (
            (action - 1) * theta.force + math.cos(3 * position) * (-theta.gravity)
        )
        velocity = min(max(velocity, -MAX_SPEED), MAX_SPEED)
        position = min(max(position + velocity, MIN_POSITION), MAX_POSITION)
        if position == MIN_POSITION and velocity < 0:
            velocity = 0.0
        terminal = position >= GOAL_POSITION and velocity >= self.goal_velocity
        return (position, velocity), -1.0, terminal

    def painter(self) -> GymnasiumPainter:
        """Gymnasium's MountainCarEnv renderer (needs pygame; see :mod:`ns_pz.envs.rendering`)."""
        from ns_pz.envs.rendering import GymnasiumPainter, pose_mountain_car

        return GymnasiumPainter("MountainCarEnv", pose_mountain_car)

    def observe(self, state: State) -> np.ndarray:
        """``[position, velocity]`` as float32."""
        return np.array(state, dtype=np.float32)

    def check_state(self, state: Any) -> State:
        """``state`` as ``(position, velocity)`` in [-1.2, 0.6] x [-0.07, 0.07].

        Raises:
            ValueError: Another length, a non-number, NaN, infinity or a value out of bounds.
        """
        return check_real_state(self, state, _STATE_FIELDS, _STATE_BOUNDS)  # type: ignore[return-value]

    def __repr__(self) -> str:
        return f"MountainCarFamily(goal_velocity={self.goal_velocity!r})"


class MountainCarContinuousFamily(EnvFamily):
    """MountainCarContinuous dynamics as a function of :class:`MountainCarContinuousParams`.

    The action is a push in [-1, 1] (shape ``(1,)``, float32); a finite action outside is
    clipped for the physics while the reward's ``-0.1 * action**2`` uses it as given, exactly
    as Gymnasium does. Reward +100 on reaching ``x >= 0.45`` with velocity ``>= goal_velocity``
    (terminal).

    Args:
        goal_velocity: Velocity the car must have at the goal (Gymnasium's constructor argument).

    Raises:
        ValueError: ``goal_velocity`` is not a real number or is NaN.
    """

    params_cls = MountainCarContinuousParams
    render_modes = ("human", "rgb_array")
    render_fps = 30
    deterministic_step = True

    def __init__(self, goal_velocity: float = 0.0) -> None:
        self.goal_velocity = _check_goal_velocity(goal_velocity)
        # NumPy compares a float32 velocity with goal_velocity cast to float32.
        self._goal_velocity_32 = float(np.float32(self.goal_velocity))
        self.observation_space = spaces.Box(
            np.array([MIN_POSITION, -MAX_SPEED], np.float32),
            np.array([MAX_POSITION, MAX_SPEED], np.float32),
            dtype=np.float32,
        )
        self.action_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def initial_state(self, rng: np.random.Generator) -> ContinuousState:
        """Position uniform in [-0.6, -0.4], at rest, in float64 (as Gymnasium)."""
        return (float(rng.uniform(low=-0.6, high=-0.4)), 0.0, False)

    def check_action(self, action: Any) -> np.ndarray:
        """A float32 array of shape ``(1,)``; finite values outside [-1, 1] are kept as given.

        Raises:
            ValueError: Not numeric, not of shape ``(1,)``, or not finite.
        """
        return check_box_action(self.action_space, action)  # type: ignore[arg-type]

    def step(  # type: ignore[override]  # θ is this family's own parameter set
        self,
        state: ContinuousState,
        action: Any,
        theta: MountainCarContinuousParams,
        rng: np.random.Generator,
    ) -> tuple[ContinuousState, float, bool]:
        """One step of Gymnasium's update, with its float32 roundings.

        ``action[0]`` is taken as a float32 value (rounded to one if it is not).
        """
        position, velocity, stored_32 = state
        push = f32(float(action[0]))
        # Gymnasium: force = min(max(action[0], -1.0), 1.0); force * power - 0.0025 * cos(3x).
        # A clipped force is a Python float (double arithmetic), an unclipped one float32.
        slope = theta.gravity * math.cos(f32(3 * position) if stored_32 else 3 * position)
        if -1.0 <= push <= 1.0:
            change = f32(f32(push * f32(theta.power)) - f32(slope))
        else:
            change = math.copysign(theta.power, push) - slope
            if stored_32:  # a float32 velocity plus a Python float: the float is cast first
                change = f32(change)
        if stored_32:
            next_state, terminal = _float32_update(
                position, velocity, change, self.goal_velocity, self._goal_velocity_32
            )
        else:
            next_state, terminal = _float64_update(position, velocity, change, self.goal_velocity)
        reward = (100.0 if terminal else 0.0) - math.pow(push, 2) * 0.1
        return next_state, reward, terminal

    def painter(self) -> GymnasiumPainter:
        """Gymnasium's Continuous_MountainCarEnv renderer (needs pygame)."""
        from ns_pz.envs.rendering import GymnasiumPainter, pose_mountain_car

        return GymnasiumPainter("Continuous_MountainCarEnv", pose_mountain_car)

    def observe(self, state: ContinuousState) -> np.ndarray:
        """``[position, velocity]`` as float32."""
        return np.array((state[0], state[1]), dtype=np.float32)

    def check_state(self, state: Any) -> ContinuousState:
        """``state`` as ``(position, velocity, stored_as_float32)`` (see :data:`ContinuousState`).

        Position in [-1.2, 0.6], velocity in [-0.07, 0.07], the flag a ``bool``.

        Raises:
            ValueError: Another shape, a non-number, NaN, infinity or a value out of bounds.
        """
        if isinstance(state, tuple) and len(state) == 3 and isinstance(state[2], bool):
            position, velocity = check_real_state(self, state[:2], _STATE_FIELDS, _STATE_BOUNDS)
            return (position, velocity, state[2])
        raise ValueError(
            f"state={state!r} is not a state of {self!r}; allowed: a tuple (position, velocity, "
            "stored_as_float32) with position in [-1.2, 0.6], velocity in [-0.07, 0.07] and a "
            "bool, as get_state() returns"
        )

    def __repr__(self) -> str:
        return f"MountainCarContinuousFamily(goal_velocity={self.goal_velocity!r})"


def _float64_update(
    position: float, velocity: float, change: float, goal_velocity: float
) -> tuple[ContinuousState, bool]:
    """Clips, wall and goal test from the float64 start state: plain double arithmetic.

    Returns the next state (stored as float32, as Gymnasium stores it) and whether it is terminal.
    """
    velocity = velocity + change
    if velocity > MAX_SPEED:
        velocity = MAX_SPEED
    elif velocity < -MAX_SPEED:
        velocity = -MAX_SPEED
    position = position + velocity
    if position > MAX_POSITION:
        position = MAX_POSITION
    elif position < MIN_POSITION:
        position = MIN_POSITION
    if position == MIN_POSITION and velocity < 0:
        velocity = 0.0
    terminal = position >= CONTINUOUS_GOAL_POSITION and velocity >= goal_velocity
    return (f32(position), f32(velocity), True), terminal


def _float32_update(
    position: float,
    velocity: float,
    change: float,
    goal_velocity: float,
    goal_velocity_32: float,
) -> tuple[ContinuousState, bool]:
    """Clips, wall and goal test from a float32 state, with NumPy's float32 semantics.

    ``change`` is a float32 value. Sums of float32 values round to float32, and a float32 value
    compares with a Python float cast to float32; a clipped value is Gymnasium's Python float
    limit, which compares exactly and is stored (and added) as its float32 rounding.

    Returns the next state (float32 values) and whether it is terminal.
    """
    velocity = f32(velocity + change)
    velocity_32 = True  # False once velocity is one of Gymnasium's Python floats
    if velocity > MAX_SPEED_32:
        velocity, velocity_32 = MAX_SPEED_32, False
    elif velocity < -MAX_SPEED_32:
        velocity, velocity_32 = -MAX_SPEED_32, False
    position = f32(position + velocity)
    if position > MAX_POSITION_32:
        position, at_wall, at_goal = MAX_POSITION_32, False, True
    elif position < MIN_POSITION_32:
        position, at_wall, at_goal = MIN_POSITION_32, True, False
    else:
        at_wall, at_goal = position == MIN_POSITION_32, position >= GOAL_32
    if at_wall and velocity < 0:
        velocity, velocity_32 = 0.0, False
    if not at_goal:
        return (position, velocity, True), False
    if velocity_32:
        return (position, velocity, True), velocity >= goal_velocity_32
    # Gymnasium compares its Python float 0.0 or ±0.07 with goal_velocity exactly.
    exact = 0.0 if velocity == 0.0 else math.copysign(MAX_SPEED, velocity)
    return (position, velocity, True), exact >= goal_velocity
