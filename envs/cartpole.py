"""CartPole with its physical constants as θ.

Same physics as Gymnasium's ``CartPole-v1`` (Euler or semi-implicit Euler integration, the same
termination thresholds, +1 per step, start state uniform in [-0.05, 0.05]^4), but written as a
function of θ: the total mass and the pole's mass-length product are properties of
:class:`CartPoleParams`, so changing ``masspole`` or ``length`` changes the dynamics exactly as
building the environment with those values would. (Gymnasium computes both once in
``__init__``; setting ``masspole`` on a live env silently keeps the stale values.)
"""

from __future__ import annotations

import math
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
STATE_FIELDS = ("x", "x_dot", "angle", "angle_dot")

THETA_THRESHOLD_RADIANS = 12 * 2 * math.pi / 360
X_THRESHOLD = 2.4


@dataclass(frozen=True, slots=True)
class CartPoleParams(Params):
    """Physical constants of CartPole (defaults: Gymnasium's).

    Bounds are physical and keep the dynamics finite: masses of at least a gram, a pole of at
    least a millimetre, at most 1000 kg (the NS-Gym paper's continuous schedule reaches 250 kg).
    """

    gravity: float = scalar(9.8, low=0.0, high=1e3, unit="m/s^2", doc="gravitational acceleration")
    masscart: float = scalar(1.0, low=1e-3, high=1e3, unit="kg", doc="mass of the cart")
    masspole: float = scalar(0.1, low=1e-3, high=1e3, unit="kg", doc="mass of the pole")
    length: float = scalar(0.5, low=1e-3, high=1e2, unit="m", doc="half the pole's length")
    force_mag: float = scalar(10.0, low=0.0, high=1e4, unit="N", doc="force of one push")
    tau: float = scalar(0.02, low=1e-4, high=1.0, unit="s", doc="time between states")

    @property
    def total_mass(self) -> float:
        """Cart plus pole mass (derived)."""
        return self.masspole + self.masscart

    @property
    def polemass_length(self) -> float:
        """Pole mass times half-length (derived)."""
        return self.masspole * self.length


class CartPoleFamily(EnvFamily):
    """CartPole dynamics as a function of :class:`CartPoleParams`.

    Args:
        kinematics_integrator: ``"euler"`` (Gymnasium's default) or ``"semi-implicit euler"``.
    """

    params_cls = CartPoleParams
    render_modes = ("human", "rgb_array")
    render_fps = 50
    deterministic_step = True

    def __init__(self, kinematics_integrator: str = "euler") -> None:
        if kinematics_integrator not in ("euler", "semi-implicit euler"):
            raise ValueError(
                f"kinematics_integrator={kinematics_integrator!r}; allowed: 'euler', "
                "'semi-implicit euler'"
            )
        self.kinematics_integrator = kinematics_integrator
        self._euler = kinematics_integrator == "euler"
        # Gymnasium declares |x| <= 4.8 and |angle| <= 0.42, which holds for its fixed constants;
        # under changing θ (a short pole, a light cart) the terminating step can overshoot, so
        # the space is unbounded to contain every reachable observation.
        self.observation_space = spaces.Box(-np.inf, np.inf, (4,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)

    def initial_state(self, rng: np.random.Generator) -> State:
        """Uniform in [-0.05, 0.05]^4 (one draw of four numbers, as Gymnasium)."""
        x, x_dot, angle, angle_dot = rng.uniform(low=-0.05, high=0.05, size=(4,)).tolist()
        return (x, x_dot, angle, angle_dot)

    def step(  # type: ignore[override]  # θ is this family's own parameter set
        self,
        state: State,
        action: int,
        theta: CartPoleParams,
        rng: np.random.Generator,
    ) -> tuple[State, float, bool]:
        """One integration step; terminal when the pole passes 12° or the cart leaves ±2.4."""
        x, x_dot, angle, angle_dot = state
        force = theta.force_mag if action == 1 else -theta.force_mag
        cos = math.cos(angle)
        sin = math.sin(angle)
        total_mass = theta.total_mass
        polemass_length = theta.polemass_length
        temp = (force + polemass_length * (angle_dot * angle_dot) * sin) / total_mass
        angle_acc = (theta.gravity * sin - cos * temp) / (
            theta.length * (4.0 / 3.0 - theta.masspole * (cos * cos) / total_mass)
        )
        x_acc = temp - polemass_length * angle_acc * cos / total_mass
        tau = theta.tau
        if self._euler:
            x = x + tau * x_dot
            x_dot = x_dot + tau * x_acc
            angle = angle + tau * angle_dot
            angle_dot = angle_dot + tau * angle_acc
        else:
            x_dot = x_dot + tau * x_acc
            x = x + tau * x_dot
            angle_dot = angle_dot + tau * angle_acc
            angle = angle + tau * angle_dot
        terminal = (
            x < -X_THRESHOLD
            or x > X_THRESHOLD
            or angle < -THETA_THRESHOLD_RADIANS
            or angle > THETA_THRESHOLD_RADIANS
        )
        return (x, x_dot, angle, angle_dot), 1.0, terminal

    def painter(self) -> GymnasiumPainter:
        """Gymnasium's CartPoleEnv renderer (needs pygame; see :mod:`ns_pz.envs.rendering`)."""
        from ns_pz.envs.rendering import GymnasiumPainter, pose_cartpole

        return GymnasiumPainter("CartPoleEnv", pose_cartpole)

    def observe(self, state: State) -> np.ndarray:
        """``[x, x_dot, angle, angle_dot]`` as float32."""
        return np.array(state, dtype=np.float32)

    def check_state(self, state: Any) -> State:
        """``state`` as a tuple of four finite floats ``(x, x_dot, angle, angle_dot)``.

        Raises:
            ValueError: Another length, a non-number, NaN or infinity.
        """
        return check_real_state(self, state, STATE_FIELDS)  # type: ignore[return-value]

    def __repr__(self) -> str:
        return f"CartPoleFamily(kinematics_integrator={self.kinematics_integrator!r})"
