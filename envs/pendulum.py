"""Pendulum with its mass, length, gravity and time step as θ.

Same physics as Gymnasium's ``Pendulum-v1``: semi-implicit Euler on a rod pivoting at one end,
torque clipped to ±2, angular velocity clipped to ±8 rad/s, cost ``angle² + 0.1·ω² +
0.001·u²`` (angle normalised into [-π, π)), never terminal, start state uniform in
[-π, π] x [-1, 1]. Gymnasium reads ``m``, ``l``, ``g`` and ``dt`` from attributes (``g`` is
also its constructor argument); here they are the θ fields ``mass``, ``length``, ``gravity``
and ``dt``, all read by the dynamics.

A float32 torque makes NumPy compute the torque terms in float32; this family reproduces those
roundings (:func:`~ns_pz.envs.continuous.f32`), so its trajectories equal Gymnasium's bit for
bit for float32 actions, the dtype of its action space.

Bounds are physical and keep the dynamics finite: mass in [0.001, 1000] kg, length in
[0.001, 100] m, gravity in [0, 1000] m/s² (zero allowed: a pendulum in free fall or in space;
negative refused, it would only relabel the top as the bottom), ``dt`` in [0.0001, 1] s.
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

State = tuple[float, float]
"""``(angle, angular_velocity)``: rad (0 is upright, not wrapped), rad/s."""

MAX_SPEED = 8.0
MAX_TORQUE = 2.0
TWO_PI = 2 * math.pi
"""The period the angle is normalised by in the cost."""
START_HIGH = np.array([math.pi, 1.0])
"""Upper corner of the uniform start box (angle, angular velocity)."""
START_LOW = -START_HIGH
"""Lower corner of the start box."""
TORQUE_COST_32 = f32(0.001)
"""The torque cost's coefficient as NumPy holds it beside a float32 torque (float32)."""


@dataclass(frozen=True, slots=True)
class PendulumParams(Params):
    """Physical constants of the Pendulum (defaults: Gymnasium's)."""

    mass: float = scalar(1.0, low=1e-3, high=1e3, unit="kg", doc="mass of the rod")
    length: float = scalar(1.0, low=1e-3, high=1e2, unit="m", doc="length of the rod")
    gravity: float = scalar(10.0, low=0.0, high=1e3, unit="m/s^2", doc="gravitational acceleration")
    dt: float = scalar(0.05, low=1e-4, high=1.0, unit="s", doc="time step")


class PendulumFamily(EnvFamily):
    """Pendulum dynamics as a function of :class:`PendulumParams`.

    The action is a torque, shape ``(1,)``, float32, in [-2, 2]; finite torques outside are
    clipped (for the physics and the cost), as Gymnasium does.
    """

    params_cls = PendulumParams
    render_modes = ("human", "rgb_array")
    render_fps = 30
    deterministic_step = True

    def __init__(self) -> None:
        high = np.array([1.0, 1.0, MAX_SPEED], dtype=np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.action_space = spaces.Box(-MAX_TORQUE, MAX_TORQUE, (1,), dtype=np.float32)

    def initial_state(self, rng: np.random.Generator) -> State:
        """Angle uniform in [-π, π], velocity in [-1, 1] (Gymnasium's default reset)."""
        angle, velocity = rng.uniform(low=START_LOW, high=START_HIGH).tolist()
        return (angle, velocity)

    def check_action(self, action: Any) -> np.ndarray:
        """A float32 array of shape ``(1,)``; finite values outside [-2, 2] are kept as given.

        Raises:
            ValueError: Not numeric, not of shape ``(1,)``, or not finite.
        """
        return check_box_action(self.action_space, action)  # type: ignore[arg-type]

    def step(  # type: ignore[override]  # θ is this family's own parameter set
        self,
        state: State,
        action: Any,
        theta: PendulumParams,
        rng: np.random.Generator,
    ) -> tuple[State, float, bool]:
        """One step of Gymnasium's update; ``action[0]`` is taken as a float32 torque."""
        angle, velocity = state
        torque = min(max(f32(float(action[0])), -MAX_TORQUE), MAX_TORQUE)
        gravity, mass, length, dt = theta.gravity, theta.mass, theta.length, theta.dt
        normalized = ((angle + math.pi) % TWO_PI) - math.pi
        # 0.001 * u**2 and 3 / (m l²) * u are float32 products; u**2 is NumPy's float32 scalar
        # power (the C library's powf, which may differ from u * u in the last bit).
        square = float(np.float32(torque) ** 2)
        cost = normalized**2 + 0.1 * velocity**2 + f32(TORQUE_COST_32 * square)
        push = f32(f32(3.0 / (mass * length**2)) * torque)
        new_velocity = velocity + (3 * gravity / (2 * length) * math.sin(angle) + push) * dt
        new_velocity = min(max(new_velocity, -MAX_SPEED), MAX_SPEED)
        return (angle + new_velocity * dt, new_velocity), -cost, False

    def check_state(self, state: Any) -> State:
        """``state`` as ``(angle, angular_velocity)``: finite, the velocity within ±8 rad/s.

        Raises:
            ValueError: Another length, a non-number, NaN, infinity or a velocity out of bounds.
        """
        bounds = (None, (-MAX_SPEED, MAX_SPEED))
        return check_real_state(self, state, ("angle", "angular_velocity"), bounds)  # type: ignore[return-value]

    def painter(self) -> GymnasiumPainter:
        """Gymnasium's PendulumEnv renderer (needs pygame; see :mod:`ns_pz.envs.rendering`)."""
        from ns_pz.envs.rendering import GymnasiumPainter, pose_pendulum

        return GymnasiumPainter("PendulumEnv", pose_pendulum)

    def observe(self, state: State) -> np.ndarray:
        """``[cos θ, sin θ, θ̇]`` as float32."""
        angle, velocity = state
        return np.array((math.cos(angle), math.sin(angle), velocity), dtype=np.float32)

    def state_from_observation(self, observation: np.ndarray) -> State:
        """The state an observation shows: the angle (in (-π, π]) from its cos and sin.

        Dynamics and observations depend on the angle only through sin and cos, so the state
        differs from the true one by a multiple of 2π at most: what a detector predicting the
        next observation needs (see :class:`~ns_pz.monitor.PredictionErrorMonitor`).
        """
        cos, sin, velocity = (float(x) for x in observation)
        return (math.atan2(sin, cos), velocity)
