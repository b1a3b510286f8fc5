"""MountainCar, MountainCarContinuous, Acrobot and Pendulum: Gymnasium's numbers, θ with effect.

Trajectories are compared with Gymnasium's *exactly* (``==`` on the float64 simulator state,
the float32 observation and the reward): the families perform Gymnasium's floating-point
operations in Gymnasium's order, including NumPy's float32 roundings, so there is no tolerance
to choose. A run with θ changed at step k is compared with a Gymnasium env given the same
value (on the attribute its ``step`` reads) before its transition k.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from ns_pz.envs.acrobot import AcrobotFamily, AcrobotParams
from ns_pz.envs.mountain_car import (
    MountainCarContinuousFamily,
    MountainCarContinuousParams,
    MountainCarFamily,
    MountainCarParams,
)
from ns_pz.envs.pendulum import PendulumFamily, PendulumParams

import ns_pz
from ns_pz.errors import ParamOutOfRange
from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate

Policy = Callable[[np.ndarray, np.random.Generator], Any]


def pump_car(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Push along the velocity (reaches the goal), with random pushes mixed in."""
    if rng.random() < 0.2:
        return int(rng.integers(3))
    return 2 if obs[1] >= 0 else 0


def pump_car_continuous(obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Push along the velocity with noise; often outside [-1, 1] (clipped), sometimes exactly ±1."""
    if rng.random() < 0.1:
        return np.array([rng.choice([-1.0, 0.0, 1.0])], np.float32)
    return np.array([math.copysign(1.2, obs[1]) + rng.normal(0.0, 0.5)], np.float32)


def pump_acrobot(obs: np.ndarray, rng: np.random.Generator) -> int:
    """Torque along the second joint's velocity (swings up within ~150 steps), some random."""
    if rng.random() < 0.1:
        return int(rng.integers(3))
    return 2 if obs[5] > 0 else 0


def random_torque(obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Uniform in [-3, 3]: a third of the torques are clipped."""
    return rng.uniform(-3.0, 3.0, (1,)).astype(np.float32)


@dataclass(frozen=True)
class Case:
    """One family next to its Gymnasium original."""

    gym_id: str
    ns_id: str
    policy: Policy
    attributes: dict[str, str | None]
    """θ field -> the Gymnasium attribute its step reads (None: a constant in Gymnasium)."""
    gym_kwargs: dict[str, Any] = field(default_factory=dict)
    ns_kwargs: dict[str, Any] = field(default_factory=dict)
    gym_attributes: dict[str, Any] = field(default_factory=dict)
    """Attributes set on Gymnasium's env after ``make`` (class constants it has no argument for)."""
    terminates: bool = True


CASES = {
    "MountainCar": Case(
        "MountainCar-v0",
        "ns_pz/MountainCar-v0",
        pump_car,
        {"gravity": "gravity", "force": "force"},
    ),
    "MountainCarContinuous": Case(
        "MountainCarContinuous-v0",
        "ns_pz/MountainCarContinuous-v0",
        pump_car_continuous,
        {"gravity": None, "power": "power"},
    ),
    "Acrobot": Case(
        "Acrobot-v1",
        "ns_pz/Acrobot-v0",
        pump_acrobot,
        {
            "link_length_1": "LINK_LENGTH_1",
            "link_length_2": "LINK_LENGTH_2",
            "link_mass_1": "LINK_MASS_1",
            "link_mass_2": "LINK_MASS_2",
            "link_com_pos_1": "LINK_COM_POS_1",
            "link_com_pos_2": "LINK_COM_POS_2",
            "link_moi": "LINK_MOI",
            "dt": "dt",
        },
    ),
    "Pendulum": Case(
        "Pendulum-v1",
        "ns_pz/Pendulum-v0",
        random_torque,
        {"mass": "m", "length": "l", "gravity": "g", "dt": "dt"},
        terminates=False,
    ),
    "MountainCar goal_velocity": Case(
        "MountainCar-v0",
        "ns_pz/MountainCar-v0",
        pump_car,
        {},
        {"goal_velocity": 0.03},
        {"goal_velocity": 0.03},
    ),
    "MountainCarContinuous goal_velocity": Case(
        "MountainCarContinuous-v0",
        "ns_pz/MountainCarContinuous-v0",
        pump_car_continuous,
        {},
        {"goal_velocity": 0.02},
        {"goal_velocity": 0.02},
    ),
}
FIELDS = [
    (name, param) for name in list(CASES)[:4] for param in CASES[name].attributes
]  # every θ field of the four families


def simulator_state(env: gym.Env) -> list[float]:
    """Gymnasium's internal state as Python floats."""
    return [float(x) for x in env.unwrapped.state]


def run_both(
    case: Case,
    *,
    seed: int,
    steps: int,
    change: tuple[str, float, int] | None = None,
    by_nature: bool = False,
    gymnasium_too: bool = True,
) -> tuple[list[np.ndarray], int]:
    """Run ns_pz's view and Gymnasium side by side, asserting equality at every step.

    Args:
        case: The pair of environments.
        seed: Seed of the first reset (later episodes continue the generators).
        steps: Transitions to run, over as many episodes as they take.
        change: ``(field, value, k)``: θ field set to ``value`` before transition ``k`` of
            every episode (by ``set_params`` or by a scripted nature), and Gymnasium's attribute
            likewise; at reset θ returns to θ_0 and the attribute to its default.
        by_nature: Make the change with ``ScriptedNature`` instead of ``set_params``.
        gymnasium_too: Compare with Gymnasium (False: run ns_pz alone, for θ Gymnasium
            cannot take).

    Returns:
        The ns_pz observations and the number of terminal steps seen.
    """
    options: dict[str, Any] = dict(case.ns_kwargs, max_episode_steps=None)
    if change is not None and by_nature:
        name, value, k = change
        options["nature"] = ScriptedNature({name: StepWiseUpdate(DiscreteScheduler({k}), [value])})
    ours = ns_pz.make_gym(case.ns_id, **options)
    theirs = gym.make(case.gym_id, **case.gym_kwargs).unwrapped
    for attribute, value in case.gym_attributes.items():
        setattr(theirs, attribute, value)
    attribute = None if change is None else case.attributes[change[0]]
    default = None if attribute is None else getattr(theirs, attribute)
    rng = np.random.default_rng(seed + 100)
    obs, _ = ours.reset(seed=seed)
    expected, _ = theirs.reset(seed=seed)
    observations, terminals, episode_step = [obs["state"]], 0, 0
    for t in range(steps):
        if gymnasium_too:
            assert obs["state"].dtype == np.float32
            assert np.array_equal(obs["state"], expected), f"step {t}"
            assert simulator_state(theirs) == list(ours._process.state)[: len(theirs.state)]
        if change is not None and episode_step == change[2]:
            if not by_nature:
                ours.set_params(**{change[0]: change[1]})
            if attribute is not None:
                setattr(theirs, attribute, change[1])
        action = case.policy(obs["state"], rng)
        obs, reward, terminated, _, _ = ours.step(action)
        expected, expected_reward, expected_terminated, _, _ = theirs.step(action)
        observations.append(obs["state"])
        if gymnasium_too:
            assert (reward, terminated) == (expected_reward, expected_terminated), f"step {t}"
        episode_step += 1
        if terminated or episode_step == 400:
            terminals += terminated
            obs, _ = ours.reset()  # θ returns to θ_0; so does Gymnasium's attribute
            if attribute is not None:
                setattr(theirs, attribute, default)
            expected, _ = theirs.reset()
            observations.append(obs["state"])
            episode_step = 0
    return observations, terminals


@pytest.mark.parametrize("name", CASES)
def test_default_trajectories_equal_gymnasium_exactly(name):
    """Same seed, same actions: start states, states, rewards and terminations all equal."""
    case = CASES[name]
    _, terminals = run_both(case, seed=3, steps=900)
    if case.terminates:
        assert terminals >= 2, "the policy should reach the goal, so the terminal test is checked"
    else:
        assert terminals == 0


def test_acrobot_torque_noise_draws_like_gymnasium():
    """torque_noise_max draws from the env's generator exactly as Gymnasium's np_random."""
    noisy_case = Case(
        "Acrobot-v1",
        "ns_pz/Acrobot-v0",
        pump_acrobot,
        {},
        ns_kwargs={"torque_noise_max": 0.4},
        gym_attributes={"torque_noise_max": 0.4},
    )
    noisy, _ = run_both(noisy_case, seed=1, steps=300)
    quiet, _ = run_both(CASES["Acrobot"], seed=1, steps=300)
    assert not all(np.array_equal(a, b) for a, b in zip(noisy, quiet, strict=False))


def changed_value(param: str, params_cls: type) -> float:
    """A value inside the bounds, far enough from the default to matter."""
    return params_cls.spec(param).default * 1.7


PARAMS = {
    "MountainCar": MountainCarParams,
    "MountainCarContinuous": MountainCarContinuousParams,
    "Acrobot": AcrobotParams,
    "Pendulum": PendulumParams,
}


@pytest.mark.parametrize("by_nature", [False, True], ids=["set_params", "nature"])
@pytest.mark.parametrize(("name", "param"), FIELDS)
def test_theta_changed_at_run_time_equals_gymnasium_built_with_it(name, param, by_nature):
    """θ changed before transition k equals Gymnasium with that value from step k on.

    Every field Gymnasium's step reads changes the trajectory; ``link_length_2``, which it
    reads only to draw, changes nothing.
    """
    case = CASES[name]
    value = changed_value(param, PARAMS[name])
    has_attribute = case.attributes[param] is not None
    changed, _ = run_both(
        case,
        seed=5,
        steps=250,
        change=(param, value, 7),
        by_nature=by_nature,
        gymnasium_too=has_attribute,
    )
    baseline, _ = run_both(case, seed=5, steps=250, gymnasium_too=False)
    same = [np.array_equal(a, b) for a, b in zip(changed, baseline, strict=False)]
    same.append(len(changed) == len(baseline))
    assert all(same[:8]), "the change must not act before transition 7"
    if param == "link_length_2":
        assert all(same), "Gymnasium's dynamics never read LINK_LENGTH_2"
    else:
        assert not all(same), f"changing {param} had no effect"


def test_continuous_gravity_is_gymnasium_constant_by_default_and_read_by_the_step():
    """Gymnasium hard-codes gravity 0.0025 in MountainCarContinuous's step; θ reads it.

    θ's default is that constant, and changing it right after reset equals building with it.
    """
    assert MountainCarContinuousParams().gravity == 0.0025
    case = CASES["MountainCarContinuous"]
    rng = np.random.default_rng(0)
    built = ns_pz.make_gym(case.ns_id, params={"gravity": 0.004})
    changed = ns_pz.make_gym(case.ns_id)
    built.reset(seed=2)
    changed.reset(seed=2)
    changed.set_params(gravity=0.004)
    for _ in range(200):
        action = case.policy(built._process.family.observe(built._process.state), rng)
        a, reward_a, done_a, *_ = built.step(action)
        b, reward_b, done_b, *_ = changed.step(action)
        assert np.array_equal(a["state"], b["state"]) and (reward_a, done_a) == (reward_b, done_b)
        if done_a:
            break
    # From rest with no push, the first velocity is -gravity * cos(3x) (rounded to float32).
    family = MountainCarContinuousFamily()
    x = -0.5
    (_, velocity, _), _, _ = family.step(
        (x, 0.0, False), np.zeros(1, np.float32), MountainCarContinuousParams(gravity=0.004), None
    )
    assert velocity == pytest.approx(-0.004 * math.cos(3 * x), rel=1e-7)


def test_out_of_range_continuous_actions_are_clipped_as_gymnasium_clips_them():
    """MountainCarContinuous clips the push but charges the action as given; Pendulum clips both."""
    car = MountainCarContinuousFamily()
    theta = MountainCarContinuousParams()
    start = (-0.5, 0.0, False)
    over, over_reward, _ = car.step(start, car.check_action([3.0]), theta, None)
    full, full_reward, _ = car.step(start, car.check_action([1.0]), theta, None)
    assert over == full
    assert over_reward == pytest.approx(-0.9) and full_reward == pytest.approx(-0.1)
    pendulum = PendulumFamily()
    state = (0.3, 0.1)
    assert pendulum.step(state, pendulum.check_action([-7.5]), PendulumParams(), None) == (
        pendulum.step(state, pendulum.check_action([-2.0]), PendulumParams(), None)
    )


def float32_neighbours(value: float, count: int) -> list[float]:
    """The ``2 * count`` float32 values nearest to ``value``, as Python floats."""
    bits = int(np.array(value, np.float32).view(np.int32))
    return np.arange(bits - count, bits + count, dtype=np.int32).view(np.float32).tolist()


@pytest.mark.parametrize(
    ("goal_velocity", "start", "index", "limit"),
    [
        (0.0, (0.44, 0.01), 0, 0.45),  # positions around float32(0.45) < 0.45: the goal
        (0.0, (-1.19, -0.01), 0, -1.2),  # positions around float32(-1.2): the wall
        (0.02, (0.46, 0.02), 1, 0.02),  # velocities around float32(0.02) < 0.02: fast enough
    ],
    ids=["goal", "wall", "goal_velocity"],
)
def test_float32_comparisons_at_goal_and_wall_match_gymnasium(goal_velocity, start, index, limit):
    """NumPy compares a float32 state with float32(limit), not with the limit itself.

    Start states one float32 step apart are chosen so that the next position (or velocity)
    runs through float32(limit), where float32 and float64 comparisons disagree; from each,
    Gymnasium and the family must take the same step.
    """
    family = MountainCarContinuousFamily(goal_velocity)
    theta = MountainCarContinuousParams()
    action = np.zeros(1, np.float32)

    def step_from(value: float) -> tuple[tuple[float, float, bool], float, bool]:
        state = np.array(start, np.float32).tolist()  # a state after a step is float32
        state[index] = value
        return family.step((state[0], state[1], True), action, theta, None)

    guess = start[index]
    for _ in range(3):  # aim the start so that the step lands next to the limit
        guess += limit - step_from(guess)[0][index]
    reference = gym.make("MountainCarContinuous-v0", goal_velocity=goal_velocity).unwrapped
    reference.reset(seed=0)
    landed = []
    for value in float32_neighbours(guess, 150):
        state = np.array(start, np.float32).tolist()
        state[index] = value
        reference.state = np.array(state, np.float32)
        expected, expected_reward, expected_terminal, _, _ = reference.step(action)
        next_state, reward, terminal = step_from(value)
        assert expected.tolist() == list(next_state[:2]), value
        assert (reward, terminal) == (expected_reward, expected_terminal), value
        landed.append(next_state[index])
    limit_32 = float(np.float32(limit))
    assert min(landed) <= limit_32 < max(landed), "the search must run through float32(limit)"


def corner_params(params_cls: type) -> list[Any]:
    """θ at every combination of each field's lower and upper bound."""
    specs = params_cls.specs()
    return [params_cls(*values) for values in itertools.product(*[(s.low, s.high) for s in specs])]


@pytest.mark.parametrize(
    ("family", "states", "actions"),
    [
        (
            MountainCarFamily(),
            [(-1.2, -0.07), (0.6, 0.07), (-0.5, 0.0), (0.49, 0.07)],
            [0, 1, 2],
        ),
        (
            MountainCarContinuousFamily(),
            [(-1.2, -0.07, True), (0.6, 0.07, True), (-0.5, 0.0, False), (0.4, 0.07, True)],
            [np.array([v], np.float32) for v in (-5.0, 0.0, 5.0)],
        ),
        (
            AcrobotFamily(torque_noise_max=1.0),
            [
                (math.pi, -math.pi, 4 * math.pi, 9 * math.pi),
                (0.0, 3.0, -4 * math.pi, -9 * math.pi),
                (-2.0, 0.5, 4 * math.pi, -9 * math.pi),
            ],
            [0, 1, 2],
        ),
        (
            PendulumFamily(),
            [(math.pi, 8.0), (-1e4, -8.0), (0.0, 0.0)],
            [np.array([v], np.float32) for v in (-2.0, 0.0, 2.0)],
        ),
    ],
    ids=["MountainCar", "MountainCarContinuous", "Acrobot", "Pendulum"],
)
def test_every_theta_in_bounds_keeps_observations_finite_and_in_space(family, states, actions):
    """From extreme reachable states, at every corner of the θ box, three steps stay in space."""
    rng = np.random.default_rng(0)
    for theta in corner_params(family.params_cls):
        for state in states:
            for action in actions:
                current = state
                for _ in range(3):
                    current, reward, _ = family.step(current, action, theta, rng)
                    observation = family.observe(current)
                    assert observation.dtype == np.float32
                    assert family.observation_space.contains(observation), (theta, current)
                    assert math.isfinite(reward)


@pytest.mark.parametrize(
    ("params_cls", "name", "value", "message"),
    [
        (MountainCarParams, "gravity", -0.001, r"MountainCarParams.gravity=-0.001 is outside"),
        (MountainCarParams, "force", 0.5, r"MountainCarParams.force=0.5 is outside \[0.0, 0.1\]"),
        (MountainCarContinuousParams, "power", math.nan, r"power=nan is not finite"),
        (AcrobotParams, "link_mass_1", 0.0, r"AcrobotParams.link_mass_1=0.0 is outside"),
        (AcrobotParams, "dt", 2.0, r"AcrobotParams.dt=2.0 is outside \[0.001, 1.0\]"),
        (AcrobotParams, "link_moi", math.inf, r"link_moi=inf is not finite"),
        (PendulumParams, "length", -1.0, r"PendulumParams.length=-1.0 is outside"),
        (PendulumParams, "gravity", "strong", r"PendulumParams.gravity='strong' is not a real"),
    ],
)
def test_invalid_theta_is_refused_with_its_name_value_and_bounds(params_cls, name, value, message):
    """Out of bounds, NaN, infinite or non-numeric θ raises ParamOutOfRange (a ValueError)."""
    with pytest.raises(ParamOutOfRange, match=message):
        params_cls(**{name: value})


def test_set_params_out_of_bounds_is_refused_at_run_time():
    """The view refuses an invalid θ and keeps the old one."""
    env = ns_pz.make_gym("ns_pz/Acrobot-v0")
    env.reset(seed=0)
    with pytest.raises(ParamOutOfRange, match=r"AcrobotParams.dt=-0.1 is outside"):
        env.set_params(dt=-0.1)
    assert env.ground_truth().theta == AcrobotParams()


@pytest.mark.parametrize("env_id", ["ns_pz/MountainCarContinuous-v0", "ns_pz/Pendulum-v0"])
@pytest.mark.parametrize(
    ("action", "message"),
    [
        (np.array([np.nan], np.float32), r"action=array\(\[nan\].*is not finite"),
        ([math.inf], r"action=\[inf\] is not finite"),
        (np.array([0.1, 0.2], np.float32), r"has shape \(2,\); allowed: shape \(1,\)"),
        (0.5, r"action=0.5 has shape \(\); allowed: shape \(1,\)"),
        (["left"], r"action=\['left'\] is not a numeric array"),
    ],
)
def test_bad_continuous_actions_are_refused(env_id, action, message):
    """NaN, infinity, a wrong shape or a non-number raises ValueError naming the action."""
    env = ns_pz.make_gym(env_id)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)


@pytest.mark.parametrize("env_id", ["ns_pz/MountainCar-v0", "ns_pz/Acrobot-v0"])
def test_bad_discrete_actions_are_refused(env_id):
    """Action 3 is outside Discrete(3)."""
    env = ns_pz.make_gym(env_id)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action=3 is outside the action space Discrete\(3\)"):
        env.step(3)


@pytest.mark.parametrize(
    ("env_id", "kwargs", "error", "message"),
    [
        ("ns_pz/MountainCar-v0", {"goal_velocity": "fast"}, ValueError, "goal_velocity='fast'"),
        ("ns_pz/MountainCarContinuous-v0", {"goal_velocity": math.nan}, ValueError, "NaN"),
        ("ns_pz/Acrobot-v0", {"torque_noise_max": -0.1}, ValueError, r"torque_noise_max=-0.1"),
        ("ns_pz/Acrobot-v0", {"torque_noise_max": math.inf}, ValueError, "finite and >= 0"),
        ("ns_pz/Acrobot-v0", {"torque_noise_max": None}, ValueError, "must be a real number"),
        ("ns_pz/Pendulum-v0", {"g": 9.81}, TypeError, r"takes no argument 'g'"),
        ("ns_pz/Acrobot-v0", {"book_or_nips": "nips"}, TypeError, "takes no argument"),
    ],
)
def test_bad_constructor_arguments_are_refused(env_id, kwargs, error, message):
    """Constructor arguments are checked before anything runs; θ is not a constructor argument."""
    with pytest.raises(error, match=message):
        ns_pz.make_gym(env_id, **kwargs)


def test_acrobot_wrap_subtracts_like_gymnasium_and_survives_huge_angles():
    """Up to 1000 turns the wrap is Gymnasium's repeated ±2π; beyond, one remainder, in range."""
    from ns_pz.envs.acrobot import wrap_angle as _wrap

    two_pi = math.pi - (-math.pi)
    for angle in (3.5, -9.0, 250.0, -6000.0):
        expected = angle
        while expected > math.pi:
            expected -= two_pi
        while expected < -math.pi:
            expected += two_pi
        assert _wrap(angle) == expected
    for angle in (1e5, -3e17, 1e300):
        assert -math.pi <= _wrap(angle) <= math.pi


def test_a_checked_continuous_action_shares_no_memory_with_the_callers():
    """Arrays, views of a buffer and ndarray subclasses come back as new arrays of their own."""
    buffer = np.array([0.0, 0.5, 0.0], np.float32)
    for family in (MountainCarContinuousFamily(), PendulumFamily()):
        for action in (
            np.array([0.5], np.float32),
            buffer[1:2],
            np.ma.array([0.5], dtype=np.float32),
            np.array([0.5]),  # float64: converted
        ):
            checked = family.check_action(action)
            assert type(checked) is np.ndarray and checked.dtype == np.float32
            assert not np.shares_memory(checked, action)
            assert checked.tolist() == [0.5]
