"""Acrobot with its link geometry, masses, inertia and time step as θ.

Same physics as Gymnasium's ``Acrobot-v1`` with its default "book" dynamics: one fourth-order
Runge-Kutta step of length ``dt`` with the torque held constant, angles wrapped into [-π, π],
angular velocities clipped to ±4π and ±9π, reward -1 per step and 0 on the terminal step,
start state uniform in [-0.1, 0.1]^4 stored as float32. The integration is written out on
Python floats, with Gymnasium's operations in Gymnasium's order, so the trajectories are equal
to Gymnasium's bit for bit (given that NumPy's float64 ``sin``/``cos`` agree with the C
library's, as they do on the platforms we test) at a fraction of the cost of its small-array
NumPy code.

Which θ fields Gymnasium's dynamics read: ``link_length_1``, ``link_mass_1``, ``link_mass_2``,
``link_com_pos_1``, ``link_com_pos_2``, ``link_moi`` (the moment of inertia of *both* links)
and ``dt``. ``link_length_2`` is never read by the dynamics nor by the terminal test (Gymnasium
uses it only to draw the second link); it is a θ field so that NS-Gym's ``LINK_LENGTH_2`` has a
place, and changing it changes nothing. The terminal test ("the tip above the bar") is
Gymnasium's ``-cos(θ1) - cos(θ1 + θ2) > 1``, which assumes unit link lengths whatever θ says.
Gravity is Gymnasium's constant 9.8 m/s².

Bounds keep every RK4 step finite from every reachable state: lengths, centre-of-mass
positions, masses and the moment of inertia in [0.01, 100], ``dt`` in [0.001, 1] s. Each field
has its own interval; nothing requires the centre of mass to lie on its link.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from ns_pz.family import EnvFamily
from ns_pz.params import Params, scalar
from ns_pz.states import check_real_state

if TYPE_CHECKING:
    from ns_pz.envs.rendering import GymnasiumPainter

State = tuple[float, float, float, float]
"""``(theta1, theta2, dtheta1, dtheta2)``: angles in rad, angular velocities in rad/s."""

GRAVITY = 9.8
MAX_VEL_1 = 4 * math.pi
MAX_VEL_2 = 9 * math.pi
TORQUES = (-1.0, 0.0, 1.0)
"""Torque of each action, N·m."""

PI = math.pi
"""The wrapping bound of the angles (Gymnasium's ``wrap(x, -pi, pi)``)."""
TWO_PI = math.pi - (-math.pi)  # Gymnasium's wrap(x, -pi, pi) steps by M - m
"""The wrapping step."""
HALF_PI = math.pi / 2.0
"""π/2 as Gymnasium computes it."""
WRAP_LOOP_LIMIT = 1000 * TWO_PI
"""Beyond this absolute angle, wrap by one remainder instead of Gymnasium's repeated subtraction."""


@dataclass(frozen=True, slots=True)
class AcrobotParams(Params):
    """Physical constants of the Acrobot (defaults: Gymnasium's class attributes)."""

    link_length_1: float = scalar(1.0, low=0.01, high=100.0, unit="m", doc="length of link 1")
    link_length_2: float = scalar(
        1.0, low=0.01, high=100.0, unit="m", doc="length of link 2 (no effect on the dynamics)"
    )
    link_mass_1: float = scalar(1.0, low=0.01, high=100.0, unit="kg", doc="mass of link 1")
    link_mass_2: float = scalar(1.0, low=0.01, high=100.0, unit="kg", doc="mass of link 2")
    link_com_pos_1: float = scalar(
        0.5, low=0.01, high=100.0, unit="m", doc="joint-to-centre-of-mass distance, link 1"
    )
    link_com_pos_2: float = scalar(
        0.5, low=0.01, high=100.0, unit="m", doc="joint-to-centre-of-mass distance, link 2"
    )
    link_moi: float = scalar(
        1.0, low=0.01, high=100.0, unit="kg m^2", doc="moment of inertia of each link"
    )
    dt: float = scalar(0.2, low=1e-3, high=1.0, unit="s", doc="integration time step")


class AcrobotFamily(EnvFamily):
    """Acrobot dynamics as a function of :class:`AcrobotParams`.

    Actions: 0, 1, 2 apply torque -1, 0, +1 at the joint between the links.

    Args:
        torque_noise_max: Half-width of uniform noise added to the torque each step (Gymnasium's
            ``torque_noise_max``); drawn from the generator passed to :meth:`step`, so only when
            it is above 0, as Gymnasium.

    Raises:
        ValueError: ``torque_noise_max`` is not a finite number >= 0.
    """

    params_cls = AcrobotParams
    render_modes = ("human", "rgb_array")
    render_fps = 15

    def __init__(self, torque_noise_max: float = 0.0) -> None:
        if isinstance(torque_noise_max, bool) or not isinstance(
            torque_noise_max, (int, float, np.integer, np.floating)
        ):
            raise ValueError(f"torque_noise_max={torque_noise_max!r} must be a real number >= 0")
        noise = float(torque_noise_max)
        if not (math.isfinite(noise) and noise >= 0.0):
            raise ValueError(f"torque_noise_max={torque_noise_max!r} must be finite and >= 0")
        self.torque_noise_max = noise
        high = np.array([1.0, 1.0, 1.0, 1.0, MAX_VEL_1, MAX_VEL_2], dtype=np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.action_space = spaces.Discrete(3)

    def initial_state(self, rng: np.random.Generator) -> State:
        """Uniform in [-0.1, 0.1]^4, rounded to float32 (one draw of four numbers, as Gymnasium)."""
        t1, t2, d1, d2 = rng.uniform(low=-0.1, high=0.1, size=(4,)).astype(np.float32).tolist()
        return (t1, t2, d1, d2)

    def step(  # type: ignore[override]  # θ is this family's own parameter set
        self,
        state: State,
        action: int,
        theta: AcrobotParams,
        rng: np.random.Generator,
    ) -> tuple[State, float, bool]:
        """One RK4 step of length ``theta.dt``; terminal when the tip rises above the bar."""
        torque = TORQUES[action]
        if self.torque_noise_max > 0:
            torque += rng.uniform(-self.torque_noise_max, self.torque_noise_max)
        derivatives = equations_of_motion(
            theta.link_length_1,
            theta.link_mass_1,
            theta.link_mass_2,
            theta.link_com_pos_1,
            theta.link_com_pos_2,
            theta.link_moi,
            torque,
            math.cos,
            math.sin,
            _square,
        )
        t1, t2, d1, d2 = rk4_step(derivatives, state, theta.dt)
        t1 = wrap_angle(t1)
        t2 = wrap_angle(t2)
        d1 = min(max(d1, -MAX_VEL_1), MAX_VEL_1)
        d2 = min(max(d2, -MAX_VEL_2), MAX_VEL_2)
        terminal = -math.cos(t1) - math.cos(t2 + t1) > 1.0
        return (t1, t2, d1, d2), (0.0 if terminal else -1.0), terminal

    def check_state(self, state: Any) -> State:
        """``state`` as four finite floats; angles any, velocities within ±4π and ±9π.

        Raises:
            ValueError: Another length, a non-number, NaN, infinity or a velocity out of bounds.
        """
        bounds = (None, None, (-MAX_VEL_1, MAX_VEL_1), (-MAX_VEL_2, MAX_VEL_2))
        fields = ("theta1", "theta2", "dtheta1", "dtheta2")
        return check_real_state(self, state, fields, bounds)  # type: ignore[return-value]

    def painter(self) -> GymnasiumPainter:
        """Gymnasium's AcrobotEnv renderer (needs pygame; see :mod:`ns_pz.envs.rendering`)."""
        from ns_pz.envs.rendering import GymnasiumPainter, pose_acrobot

        return GymnasiumPainter("AcrobotEnv", pose_acrobot)

    def observe(self, state: State) -> np.ndarray:
        """``[cos θ1, sin θ1, cos θ2, sin θ2, dθ1, dθ2]`` as float32."""
        t1, t2, d1, d2 = state
        return np.array(
            (math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2), d1, d2), dtype=np.float32
        )

    def state_from_observation(self, observation: np.ndarray) -> State:
        """The state an observation shows: both angles (in (-π, π]) from their cos and sin.

        The dynamics wrap the angles and use them only through sin and cos, so this is the
        state up to the wrapping: what a detector predicting the next observation needs (see
        :class:`~ns_pz.monitor.PredictionErrorMonitor`).
        """
        c1, s1, c2, s2, d1, d2 = (float(x) for x in observation)
        return (math.atan2(s1, c1), math.atan2(s2, c2), d1, d2)

    def __repr__(self) -> str:
        return f"AcrobotFamily(torque_noise_max={self.torque_noise_max!r})"


Derivatives = Callable[[Any, Any, Any, Any], tuple[Any, Any, Any, Any]]
"""``f(θ1, θ2, dθ1, dθ2) -> (dθ1, dθ2, ddθ1, ddθ2)``, of floats or of arrays of rows."""


def _square(x: float) -> float:
    return x**2


def equations_of_motion(
    l1: Any,
    m1: Any,
    m2: Any,
    lc1: Any,
    lc2: Any,
    moi: Any,
    torque: Any,
    cos: Callable[[Any], Any],
    sin: Callable[[Any], Any],
    square: Callable[[Any], Any],
) -> Derivatives:
    """Gymnasium's "book" equations of motion under one θ and torque.

    The arguments are floats (the scalar step) or arrays of rows (the batched kernel of
    :mod:`ns_pz.envs.batched`), with the ``cos``, ``sin`` and squaring that give Gymnasium's
    bits for them (``x ** 2`` is the C library's ``pow``, not ``x * x``). The θ-only products
    are computed once per step, grouped exactly as Gymnasium's left-to-right evaluation groups
    them, so every value matches to the bit.
    """
    i1 = i2 = moi
    d1_a = m1 * square(lc1)
    d1_b = square(l1) + square(lc2)
    d1_c = 2 * l1 * lc2
    d2_a = square(lc2)
    d2_b = l1 * lc2
    phi2_a = m2 * lc2 * GRAVITY
    phi1_a = -m2 * l1 * lc2
    phi1_b = 2 * m2 * l1 * lc2
    phi1_c = (m1 * lc1 + m2 * l1) * GRAVITY
    coriolis = m2 * l1 * lc2
    den_a = m2 * square(lc2) + i2

    def derivatives(theta1: Any, theta2: Any, dtheta1: Any, dtheta2: Any) -> tuple[Any, ...]:
        cos2 = cos(theta2)
        sin2 = sin(theta2)
        d1 = d1_a + m2 * (d1_b + d1_c * cos2) + i1 + i2
        d2 = m2 * (d2_a + d2_b * cos2) + i2
        phi2 = phi2_a * cos(theta1 + theta2 - HALF_PI)
        phi1 = (
            phi1_a * square(dtheta2) * sin2
            - phi1_b * dtheta2 * dtheta1 * sin2
            + phi1_c * cos(theta1 - HALF_PI)
            + phi2
        )
        ddtheta2 = (torque + d2 / d1 * phi1 - coriolis * square(dtheta1) * sin2 - phi2) / (
            den_a - square(d2) / d1
        )
        ddtheta1 = -(d2 * ddtheta2 + phi1) / d1
        return dtheta1, dtheta2, ddtheta1, ddtheta2

    return derivatives  # type: ignore[return-value]


def rk4_step(derivatives: Derivatives, state: Any, dt: Any) -> tuple[Any, Any, Any, Any]:
    """Gymnasium's RK4 step of length ``dt`` from ``state`` (before wrapping and clipping).

    ``y0 + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)``, element by element, in NumPy's order; floats
    or arrays of rows.
    """
    t1, t2, d1, d2 = state
    half = dt / 2.0
    k1 = derivatives(t1, t2, d1, d2)
    k2 = derivatives(t1 + half * k1[0], t2 + half * k1[1], d1 + half * k1[2], d2 + half * k1[3])
    k3 = derivatives(t1 + half * k2[0], t2 + half * k2[1], d1 + half * k2[2], d2 + half * k2[3])
    k4 = derivatives(t1 + dt * k3[0], t2 + dt * k3[1], d1 + dt * k3[2], d2 + dt * k3[3])
    sixth = dt / 6.0
    return (
        t1 + sixth * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
        t2 + sixth * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
        d1 + sixth * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]),
        d2 + sixth * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3]),
    )


def wrap_angle(angle: float) -> float:
    """Gymnasium's ``wrap(angle, -pi, pi)``: add or subtract 2π until inside [-π, π].

    Angles beyond 1000 turns (reachable only with extreme θ) are first reduced by one
    ``math.remainder``: Gymnasium would loop over a thousand times there, and forever past
    2^53 turns.
    """
    if not -WRAP_LOOP_LIMIT <= angle <= WRAP_LOOP_LIMIT:
        angle = math.remainder(angle, TWO_PI)
    while angle > PI:
        angle = angle - TWO_PI
    while angle < -PI:
        angle = angle + TWO_PI
    return angle
