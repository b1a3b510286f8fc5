"""Batched dynamics: a family's ``step`` as numpy array functions of N states and N θ.

Each kernel computes, for a batch of sub-environments at once, exactly what the family's scalar
``step`` computes for one: the same floating-point operations in the same order, so results are
equal bit for bit (the vector env's tests compare them with N single views). θ arrives as an
``(N, D)`` float64 array of rows laid out as :meth:`ns_pz.params.Params.flat`.

Randomness: a kernel declares how many uniform doubles a transition and a start state consume
(:attr:`~ns_pz.vector.BatchKernel.step_uniforms`, ``reset_uniforms``); the vector env draws them
from each sub-environment's own generator, in the order the scalar family would (NumPy's
``uniform(low, high)`` is ``low + (high - low) * u`` of one such double). The classic-control
kernels draw only start states (Acrobot also one uniform per transition with torque noise), the
grid worlds one uniform per transition and per start.

Where NumPy's array functions round differently from what the scalar step calls (Python's
``x ** 2`` is the C library's ``pow``; a float32 square is NumPy's scalar ``powf``), the kernel
calls the scalar function per element (:func:`_pow2`, :func:`_powf2`) rather than give up
equality; ``sin`` and ``cos`` agree.

:func:`kernel_for` picks the kernel of a family: every shipped classic-control and grid family
has one; other families (MuJoCo, custom ones) get :class:`~ns_pz.vector.LoopKernel`, which
calls the scalar ``step`` per sub-environment: correct, not fast.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from ns_pz.envs.acrobot import (
    MAX_VEL_1,
    MAX_VEL_2,
    PI,
    WRAP_LOOP_LIMIT,
    AcrobotFamily,
    equations_of_motion,
    rk4_step,
    wrap_angle,
)
from ns_pz.envs.acrobot import TORQUES as ACROBOT_TORQUES
from ns_pz.envs.acrobot import TWO_PI as ACROBOT_TWO_PI
from ns_pz.envs.cartpole import THETA_THRESHOLD_RADIANS, X_THRESHOLD, CartPoleFamily
from ns_pz.envs.grid import SlipGridFamily
from ns_pz.envs.mountain_car import (
    CONTINUOUS_GOAL_POSITION,
    GOAL_32,
    GOAL_POSITION,
    MAX_POSITION,
    MAX_POSITION_32,
    MAX_SPEED,
    MAX_SPEED_32,
    MIN_POSITION,
    MIN_POSITION_32,
    ContinuousState,
    MountainCarContinuousFamily,
    MountainCarFamily,
)
from ns_pz.envs.pendulum import MAX_SPEED as PENDULUM_MAX_SPEED
from ns_pz.envs.pendulum import (
    MAX_TORQUE,
    START_HIGH,
    START_LOW,
    TORQUE_COST_32,
    TWO_PI,
    PendulumFamily,
)

from ns_pz.family import EnvFamily
from ns_pz.vector import ArrayKernel, BatchKernel, LoopKernel


class CartPoleKernel(ArrayKernel):
    """CartPole: states ``(N, 4)`` float64.

    θ columns: gravity, masscart, masspole, length, force_mag, tau.
    """

    reset_uniforms = 4

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Uniform in [-0.05, 0.05]^4: ``low + (high - low) * u``, as NumPy's ``uniform``."""
        return _uniform(-0.05, 0.05, uniforms)

    def __init__(self, family: CartPoleFamily) -> None:
        super().__init__(family, state_shape=(4,), state_dtype=np.float64)
        self._euler = family.kinematics_integrator == "euler"
        self._ones = np.ones(0)

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One integration step for every row (the scalar step's operations, in its order)."""
        x, x_dot, angle, angle_dot = states.T
        gravity, masscart, masspole, length, force_mag, tau = theta.T
        force = np.where(actions == 1, force_mag, -force_mag)
        cos = np.cos(angle)
        sin = np.sin(angle)
        total_mass = masspole + masscart
        polemass_length = masspole * length
        temp = (force + polemass_length * (angle_dot * angle_dot) * sin) / total_mass
        angle_acc = (gravity * sin - cos * temp) / (
            length * (4.0 / 3.0 - masspole * (cos * cos) / total_mass)
        )
        x_acc = temp - polemass_length * angle_acc * cos / total_mass
        out = np.empty_like(states)
        if self._euler:
            out[:, 0] = x + tau * x_dot
            out[:, 1] = x_dot + tau * x_acc
            out[:, 2] = angle + tau * angle_dot
            out[:, 3] = angle_dot + tau * angle_acc
        else:
            out[:, 1] = x_dot + tau * x_acc
            out[:, 0] = x + tau * out[:, 1]
            out[:, 3] = angle_dot + tau * angle_acc
            out[:, 2] = angle + tau * out[:, 3]
        # |x| > bound is the scalar step's two comparisons in one (both false for NaN).
        terminal = np.abs(out[:, 0]) > X_THRESHOLD
        terminal |= np.abs(out[:, 2]) > THETA_THRESHOLD_RADIANS
        ones = self._ones
        if len(ones) != len(states):
            ones = self._ones = np.ones(len(states))
            ones.flags.writeable = False  # shared between calls: the vector env copies it
        return out, ones, terminal

    def observe(self, states: np.ndarray) -> np.ndarray:
        """``[x, x_dot, angle, angle_dot]`` as float32."""
        return states.astype(np.float32)


class MountainCarKernel(ArrayKernel):
    """MountainCar (discrete pushes): states ``(N, 2)``; θ columns gravity, force."""

    reset_uniforms = 1

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Position uniform in [-0.6, -0.4], velocity 0 (as the family's ``initial_state``)."""
        position = _uniform(-0.6, -0.4, uniforms[:, 0])
        return np.stack((position, np.zeros_like(position)), axis=1)

    def __init__(self, family: MountainCarFamily) -> None:
        super().__init__(family, state_shape=(2,), state_dtype=np.float64)
        self._family = family

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scalar step's update for every row."""
        position, velocity = states.T
        gravity, force = theta.T
        velocity = velocity + ((actions - 1) * force + np.cos(3 * position) * (-gravity))
        velocity = np.minimum(np.maximum(velocity, -MAX_SPEED), MAX_SPEED)
        position = position + velocity
        position = np.minimum(np.maximum(position, MIN_POSITION), MAX_POSITION)
        velocity = np.where((position == MIN_POSITION) & (velocity < 0), 0.0, velocity)
        terminal = (position >= GOAL_POSITION) & (velocity >= self._family.goal_velocity)
        out = np.stack((position, velocity), axis=1)
        return out, np.full(len(states), -1.0), terminal

    def observe(self, states: np.ndarray) -> np.ndarray:
        """``[position, velocity]`` as float32."""
        return states.astype(np.float32)


class MountainCarContinuousKernel(ArrayKernel):
    """MountainCarContinuous: states ``(N, 3)`` (position, velocity, 1.0 once stored as float32).

    Gymnasium's start state is float64 and every later state float32, and a step's arithmetic
    depends on which (see :mod:`ns_pz.envs.mountain_car`): both branches are computed for every
    row, each with the scalar step's roundings, and each row keeps its own; θ columns gravity,
    power.
    """

    reset_uniforms = 1

    def __init__(self, family: MountainCarContinuousFamily) -> None:
        super().__init__(family, state_shape=(3,), state_dtype=np.float64)
        self._goal = family.goal_velocity
        self._goal_32 = float(np.float32(family.goal_velocity))

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Position uniform in [-0.6, -0.4], at rest, float64 (as ``initial_state``)."""
        position = _uniform(-0.6, -0.4, uniforms[:, 0])
        zeros = np.zeros_like(position)
        return np.stack((position, zeros, zeros), axis=1)

    def pack(self, state: ContinuousState) -> Any:  # type: ignore[override]
        """``(position, velocity, stored_as_float32)`` as a row (the flag as 0.0 / 1.0)."""
        return (state[0], state[1], 1.0 if state[2] else 0.0)

    def unpack(self, row: np.ndarray) -> ContinuousState:
        """A row as the family's state (the flag back as a bool)."""
        position, velocity, stored = row.tolist()
        return (position, velocity, stored != 0.0)

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scalar step's float64 (first step) or float32 arithmetic, row by row."""
        position, velocity = states[:, 0], states[:, 1]
        stored = states[:, 2] != 0.0
        gravity, power = theta.T
        push = actions[:, 0].astype(np.float64)
        three = 3 * position
        slope = gravity * np.cos(np.where(stored, _f32(three), three))
        clipped = np.copysign(power, push) - slope
        change = np.where(
            (push >= -1.0) & (push <= 1.0),
            _f32(_f32(push * _f32(power)) - _f32(slope)),
            np.where(stored, _f32(clipped), clipped),
        )
        # From a float64 state (the first step): plain double arithmetic, then stored as float32.
        v64 = np.minimum(np.maximum(velocity + change, -MAX_SPEED), MAX_SPEED)
        p64 = np.minimum(np.maximum(position + v64, MIN_POSITION), MAX_POSITION)
        v64 = np.where((p64 == MIN_POSITION) & (v64 < 0), 0.0, v64)
        end64 = (p64 >= CONTINUOUS_GOAL_POSITION) & (v64 >= self._goal)
        # From a float32 state: float32 sums; a clipped value is Gymnasium's Python float.
        v32 = _f32(velocity + change)
        exact = (v32 <= MAX_SPEED_32) & (v32 >= -MAX_SPEED_32)
        v32 = np.minimum(np.maximum(v32, -MAX_SPEED_32), MAX_SPEED_32)
        p32 = _f32(position + v32)
        above, below = p32 > MAX_POSITION_32, p32 < MIN_POSITION_32
        p32 = np.minimum(np.maximum(p32, MIN_POSITION_32), MAX_POSITION_32)
        at_wall = below | (~above & (p32 == MIN_POSITION_32))
        at_goal = above | (~below & (p32 >= GOAL_32))
        stop = at_wall & (v32 < 0)
        v32 = np.where(stop, 0.0, v32)
        exact &= ~stop
        python_float = np.where(v32 == 0.0, 0.0, np.copysign(MAX_SPEED, v32))
        end32 = at_goal & np.where(exact, v32 >= self._goal_32, python_float >= self._goal)
        out = np.empty_like(states)
        out[:, 0] = np.where(stored, p32, _f32(p64))
        out[:, 1] = np.where(stored, v32, _f32(v64))
        out[:, 2] = 1.0
        terminal = np.where(stored, end32, end64)
        reward = np.where(terminal, 100.0, 0.0) - _pow2(push) * 0.1
        return out, reward, terminal

    def observe(self, states: np.ndarray) -> np.ndarray:
        """``[position, velocity]`` as float32."""
        return states[:, :2].astype(np.float32)


class SlipGridKernel(ArrayKernel):
    """The slip grid worlds: states ``(N,)`` int64 cell indices; one uniform per transition.

    The outcome of a transition is the first slip outcome whose cumulative probability exceeds
    the uniform (cumulated left to right, as the scalar step does); if rounding leaves the sum
    below it, the last outcome of positive probability.
    """

    step_uniforms = 1
    reset_uniforms = 1

    def __init__(self, family: SlipGridFamily) -> None:
        super().__init__(family, state_shape=(), state_dtype=np.int64)
        next_states, rewards, terminals = family._structure
        self._next = next_states.ravel()
        self._rewards = rewards.ravel()
        self._terminals = terminals.ravel()
        self._actions, count = next_states.shape[1:]
        slices = {spec.name: start for spec, start, _ in family.params_cls.flat_layout()}
        starts = np.array([slices[name] for name in family._slip_param], np.int64)
        self._columns = starts[:, None] + np.arange(count)
        self._one_vector = (
            slice(int(starts[0]), int(starts[0]) + count)
            if len(set(starts.tolist())) == 1
            else None
        )
        self._start_states = np.array(family.start_states, np.int64)
        self._start_cumulative = np.cumsum(family._start_probs)

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Start cells, one uniform each (as the family's ``initial_state``)."""
        cumulative = self._start_cumulative
        index = np.minimum((cumulative[None, :] <= uniforms).sum(1), len(cumulative) - 1)
        return self._start_states[index]

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sample one slip outcome per row with that row's θ."""
        one = self._one_vector
        if one is not None:  # one slip vector for every cell: a column slice
            probs = theta[:, one]
        else:
            probs = theta[np.arange(len(states))[:, None], self._columns[states]]
        cumulative = np.cumsum(probs, axis=1)
        k = np.count_nonzero(cumulative <= uniforms[:, None], axis=1)
        count = probs.shape[1]
        if k.max() == count:  # rounding: the last outcome of positive probability, as `step`
            short = k == count
            positive = probs[short] > 0.0
            k[short] = count - 1 - np.argmax(positive[:, ::-1], axis=1)
        flat = (states * self._actions + actions) * count + k
        return self._next[flat], self._rewards[flat], self._terminals[flat]

    def observe(self, states: np.ndarray) -> np.ndarray:
        """The cell indices."""
        return states.copy()


class PendulumKernel(ArrayKernel):
    """Pendulum: states ``(N, 2)`` (angle, angular velocity); θ columns mass, length, gravity, dt.

    The scalar step squares with Python's ``**`` (the C library's ``pow``, which is not always
    the correctly rounded ``x * x``) and the float32 torque with NumPy's scalar power (``powf``,
    not always the float32 rounding of the exact square). NumPy's array power is neither, so
    those squares call the scalar functions per element (:func:`_pow2`, :func:`_powf2`); the
    rest is array arithmetic in the scalar step's order.
    """

    reset_uniforms = 2

    def __init__(self, family: PendulumFamily) -> None:
        super().__init__(family, state_shape=(2,), state_dtype=np.float64)

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Angle uniform in [-π, π], velocity in [-1, 1] (as the family's ``initial_state``)."""
        return START_LOW + (START_HIGH - START_LOW) * uniforms

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scalar step's update for every row (same operations, same order)."""
        angle, velocity = states[:, 0], states[:, 1]
        mass, length, gravity, dt = theta.T
        torque = np.minimum(np.maximum(actions[:, 0].astype(np.float64), -MAX_TORQUE), MAX_TORQUE)
        normalized = np.remainder(angle + math.pi, TWO_PI) - math.pi
        cost = _pow2(normalized) + 0.1 * _pow2(velocity)
        cost += _f32(TORQUE_COST_32 * _powf2(torque))
        push = _f32(_f32(3.0 / (mass * _pow2(length))) * torque)
        new_velocity = velocity + (3 * gravity / (2 * length) * np.sin(angle) + push) * dt
        new_velocity = np.minimum(np.maximum(new_velocity, -PENDULUM_MAX_SPEED), PENDULUM_MAX_SPEED)
        out = np.empty_like(states)
        out[:, 0] = angle + new_velocity * dt
        out[:, 1] = new_velocity
        return out, -cost, np.zeros(len(states), np.bool_)

    def observe(self, states: np.ndarray) -> np.ndarray:
        """``[cos θ, sin θ, θ̇]`` as float32."""
        angle = states[:, 0]
        return np.stack((np.cos(angle), np.sin(angle), states[:, 1]), axis=1).astype(np.float32)


class AcrobotKernel(ArrayKernel):
    """Acrobot: states ``(N, 4)`` (θ1, θ2, dθ1, dθ2); θ columns in :class:`AcrobotParams` order.

    The scalar step's own equations and RK4 step (:func:`ns_pz.envs.acrobot.equations_of_motion`,
    :func:`~ns_pz.envs.acrobot.rk4_step`) on arrays of rows; the squares call the C library's
    ``pow`` per element (:func:`_pow2`), as Python's ``**`` does. With torque noise, one uniform per
    transition, drawn as the scalar step draws it.
    """

    reset_uniforms = 4

    def __init__(self, family: AcrobotFamily) -> None:
        super().__init__(family, state_shape=(4,), state_dtype=np.float64)
        self._noise = family.torque_noise_max
        self.step_uniforms = 1 if self._noise > 0 else 0
        self._torques = np.array(ACROBOT_TORQUES)

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Uniform in [-0.1, 0.1]^4, rounded to float32 (as the family's ``initial_state``)."""
        return _uniform(-0.1, 0.1, uniforms).astype(np.float32).astype(np.float64)

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One RK4 step of length ``dt`` for every row."""
        torque = self._torques[actions]
        if self._noise > 0:
            torque = torque + _uniform(-self._noise, self._noise, uniforms)
        l1, _, m1, m2, lc1, lc2, moi, dt = theta.T
        derivatives = equations_of_motion(l1, m1, m2, lc1, lc2, moi, torque, np.cos, np.sin, _pow2)
        t1, t2, v1, v2 = rk4_step(derivatives, states.T, dt)
        out = np.empty_like(states)
        out[:, 0] = _wrap_angles(t1)
        out[:, 1] = _wrap_angles(t2)
        out[:, 2] = np.minimum(np.maximum(v1, -MAX_VEL_1), MAX_VEL_1)
        out[:, 3] = np.minimum(np.maximum(v2, -MAX_VEL_2), MAX_VEL_2)
        t1, t2 = out[:, 0], out[:, 1]
        terminal = -np.cos(t1) - np.cos(t2 + t1) > 1.0
        return out, np.where(terminal, 0.0, -1.0), terminal

    def observe(self, states: np.ndarray) -> np.ndarray:
        """``[cos θ1, sin θ1, cos θ2, sin θ2, dθ1, dθ2]`` as float32."""
        t1, t2 = states[:, 0], states[:, 1]
        columns = (np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2), states[:, 2], states[:, 3])
        return np.stack(columns, axis=1).astype(np.float32)


def _wrap_angles(angles: np.ndarray) -> np.ndarray:
    """:func:`ns_pz.envs.acrobot.wrap_angle` of every element (repeated steps of 2π)."""
    far = np.flatnonzero(~(np.abs(angles) <= WRAP_LOOP_LIMIT))
    for i in far:
        angles[i] = wrap_angle(float(angles[i]))
    while True:
        above = angles > PI
        if not above.any():
            break
        angles[above] = angles[above] - ACROBOT_TWO_PI
    while True:
        below = angles < -PI
        if not below.any():
            break
        angles[below] = angles[below] + ACROBOT_TWO_PI
    return angles


_POW = np.frompyfunc(math.pow, 2, 1)


def _pow2(x: np.ndarray) -> np.ndarray:
    """``x ** 2`` of every element exactly as Python computes it (the C library's ``pow``)."""
    return _POW(x, 2.0).astype(np.float64)


def _f32(x: np.ndarray) -> np.ndarray:
    """Every element rounded to float32 (ties to even), back as float64, as ``f32`` does."""
    return x.astype(np.float32).astype(np.float64)


_POWF = np.frompyfunc(lambda torque: float(np.float32(torque) ** 2), 1, 1)


def _powf2(torque: np.ndarray) -> np.ndarray:
    """``float(np.float32(t) ** 2)`` of every element: NumPy's scalar float32 power (``powf``).

    Not the float32 rounding of the exact square: ``powf`` is off by one unit in about 5 of
    10,000 cases here (tested), so each element calls it (about 0.4 µs each).
    """
    return _POWF(torque).astype(np.float64)


def _uniform(low: float, high: float, uniforms: np.ndarray) -> np.ndarray:
    """``Generator.uniform(low, high)`` from its underlying doubles: ``low + (high - low) * u``."""
    return low + (np.float64(high) - np.float64(low)) * uniforms


def kernel_for(family: EnvFamily) -> BatchKernel:
    """The fastest exact kernel for ``family`` (a loop over the scalar step if none is batched).

    A kernel reproduces one class's ``step``: a subclass gets it only among the grid worlds,
    which share the slip step; a subclass of a classic-control family, which may change the
    dynamics, gets the loop.
    """
    if type(family) is CartPoleFamily:
        return CartPoleKernel(family)
    if isinstance(family, SlipGridFamily) and type(family).step is SlipGridFamily.step:
        return SlipGridKernel(family)
    if type(family) is MountainCarFamily:
        return MountainCarKernel(family)
    if type(family) is PendulumFamily:
        return PendulumKernel(family)
    if type(family) is MountainCarContinuousFamily:
        return MountainCarContinuousKernel(family)
    if type(family) is AcrobotFamily:
        return AcrobotKernel(family)
    return LoopKernel(family)
