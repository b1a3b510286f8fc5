"""Detector monitors on synthetic streams with known change points, and through the envs.

Synthetic streams draw each transition's state and action uniformly (so every run sees the same
mix of informative transitions) and step the family under θ_0 before the change and θ_1 from the
change on. The bounds are stated per test, with the figures measured when they were set.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from ns_pz.envs.cartpole import CartPoleFamily, CartPoleParams
from ns_pz.envs.cliff_walking import CliffWalkingFamily, CliffWalkingParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams
from ns_pz.envs.mountain_car import MountainCarContinuousFamily

import ns_pz
from ns_pz.monitor import (
    NoisyOracleMonitor,
    PredictionErrorMonitor,
    TabularCusumMonitor,
    detection_metrics,
    score_episode,
)
from ns_pz.nature import (
    DiscreteScheduler,
    DistributionStepWiseUpdate,
    ScriptedNature,
    StepWiseUpdate,
)


def _observation(t: int, state, action, next_state) -> dict:
    return {
        "last_state": state,
        "last_action": action,
        "last_reward": np.zeros(1, np.float32),
        "state": next_state,
        "relative_time": np.array([t + 1], np.float32),
    }


def tabular_stream(family, theta0, theta1, change: int, steps: int, seed: int) -> Iterator[dict]:
    """Transitions from uniform non-terminal states and actions; θ_1 from ``change`` on."""
    rng = np.random.default_rng(seed)
    live = [s for s in range(family.observation_space.n) if not family.is_terminal_state(s)]
    for t in range(steps):
        state, action = int(rng.choice(live)), int(rng.integers(family.action_space.n))
        next_state, _, _ = family.step(state, action, theta1 if t >= change else theta0, rng)
        yield _observation(t, state, action, next_state)


def cartpole_stream(theta0, theta1, change: int, steps: int, seed: int) -> Iterator[dict]:
    """CartPole transitions from uniform states near upright, observed in float32."""
    family = CartPoleFamily()
    rng = np.random.default_rng(seed)
    for t in range(steps):
        state = tuple(rng.uniform(-0.2, 0.2, 4).astype(np.float32).tolist())
        action = int(rng.integers(2))
        next_state, _, _ = family.step(state, action, theta1 if t >= change else theta0, rng)
        yield _observation(t, np.array(state, np.float32), action, family.observe(next_state))


def run(monitor, stream) -> tuple[list[int], object]:
    """Feed a stream to a fresh episode of ``monitor``: its alarms and final memory."""
    memory = monitor.initial_memory()
    rng = np.random.default_rng(0)
    for observation in stream:
        monitor.notify(observation, None, memory, rng)
    return memory.alarms, memory


# -- scoring ---------------------------------------------------------------------------------
def test_score_episode_rules():
    """First alarm in a change's interval detects it; others are false; no alarm is a miss."""
    scored = score_episode([10, 50], [3, 12, 20, 80], steps=100)
    assert scored.delays == (2, 30)  # 12 detects 10; 80 detects 50
    assert scored.false_alarms == 2  # 3 (before any change) and 20 (second for change 10)
    assert scored.missed == 0
    assert scored.false_alarms_per_1000 == pytest.approx(20.0)
    assert score_episode([10, 50], [60], steps=100).missed == 1  # 10 has no alarm before 50
    late = score_episode([10], [40], steps=100, max_delay=20)
    assert (late.delays, late.missed, late.false_alarms) == ((), 1, 1)


def test_detection_metrics_pools_episodes():
    """Delays, misses and false alarms add up over episodes; the rate pools the steps."""
    summary = detection_metrics([([5], [5], 100), ([5], [9, 50], 100), ([], [1], 50)])
    assert (summary.episodes, summary.steps, summary.changes) == (3, 250, 2)
    assert (summary.detected, summary.missed, summary.false_alarms) == (2, 0, 2)
    assert summary.mean_delay == pytest.approx(2.0)
    assert summary.false_alarms_per_1000 == pytest.approx(8.0)
    assert np.isnan(detection_metrics([([5], [], 10)]).mean_delay)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"change_times": [5, 5], "alarm_times": [], "steps": 10}, "strictly increasing"),
        ({"change_times": [12], "alarm_times": [], "steps": 10}, r"must lie in \[0, steps\)"),
        ({"change_times": [], "alarm_times": [], "steps": -1}, "steps=-1"),
        ({"change_times": [], "alarm_times": [], "steps": 5, "max_delay": -2}, "max_delay=-2"),
    ],
)
def test_score_episode_rejects_bad_input(kwargs, match):
    """Bad times, steps or max_delay name the parameter."""
    with pytest.raises(ValueError, match=match):
        score_episode(**kwargs)


def test_malformed_scoring_input_is_named_and_numpy_settings_are_numbers():
    """Times that are no sequence, an episode that is no triple, a flag that is no bool.

    ``score_episode(5, [], 10)`` said "'int' object is not iterable"; ``detection_metrics``
    with a pair said "not enough values to unpack"; ``detection_reward("no", False)`` read the
    string as true. NumPy numbers pass where Python's do (np.float32(0.1) was refused).
    """
    from ns_pz.monitor import MonitorFeatures, NoisyOracleMonitor, detection_reward

    with pytest.raises(TypeError, match="change_times=5 must be a sequence"):
        score_episode(5, [], 10)
    with pytest.raises(TypeError, match="alarm_times=None must be a sequence"):
        score_episode([5], None, 10)
    assert score_episode(np.array([5]), np.array([6]), 10).delays == (1,)
    with pytest.raises(ValueError, match=r"episodes\[1\]=\(\[5\], \[6\]\) must be"):
        detection_metrics([([5], [5], 10), ([5], [6])])
    with pytest.raises(TypeError, match="undetected_change='no' must be a bool"):
        detection_reward("no", False)
    with pytest.raises(TypeError, match="alarm=1 must be a bool"):
        detection_reward(False, 1)
    assert detection_reward(np.bool_(True), np.bool_(False)) == (-1.0, True)
    assert NoisyOracleMonitor(miss_probability=np.float32(0.5)).miss_probability == 0.5
    assert MonitorFeatures(horizon=5, unlikely=np.float32(0.25)).unlikely == 0.25
    assert TabularCusumMonitor(scalar_points=np.int64(5)).scalar_points == 5
    with pytest.raises(ValueError, match="grid_step=True"):
        TabularCusumMonitor(grid_step=True)
    with pytest.raises(ValueError, match="as a float it is 0.05000000074505806"):
        TabularCusumMonitor(grid_step=np.float32(0.05))


def test_detection_reward_sums_to_the_scores():
    """Summed over an episode: -(delays + undetected time of misses) - λ·false alarms."""
    from ns_pz.monitor import detection_reward

    rng = np.random.default_rng(3)
    for _ in range(200):
        steps = int(rng.integers(1, 60))
        changes = sorted({int(x) for x in rng.integers(0, steps, rng.integers(0, 4))})
        alarms = sorted({int(x) for x in rng.integers(0, steps, rng.integers(0, 5))})
        pending, total = False, 0.0
        for t in range(steps):
            pending = pending or t in changes
            reward, pending = detection_reward(pending, t in alarms, false_alarm_cost=3.0)
            total += reward
        scored = score_episode(changes, alarms, steps)
        undetected = 0
        for i, start in enumerate(changes):  # a missed change costs until the next / the end
            end = changes[i + 1] if i + 1 < len(changes) else steps
            if not any(start <= a < end for a in alarms):
                undetected += end - start
        assert total == -(sum(scored.delays) + undetected) - 3.0 * scored.false_alarms
    with pytest.raises(ValueError, match="false_alarm_cost=-1"):
        detection_reward(True, False, false_alarm_cost=-1)


# -- tabular CUSUM ---------------------------------------------------------------------------
FL0 = FrozenLakeParams(slip=(0.7, 0.15, 0.15))
FL1 = FrozenLakeParams(slip=(0.4, 0.3, 0.3))


def test_tabular_cusum_detects_a_frozenlake_change():
    """0.7 → 0.4 at 300 of 1,300 (20 runs): measured mean delay 44, 0.4 false alarms / 1,000.

    Bounds: every change detected but at most one, mean delay <= 80, <= 2 false alarms per
    1,000 steps, and the believed slip ends within 0.1 (total variation) of the truth.
    """
    family = FrozenLakeFamily()
    monitor = TabularCusumMonitor()
    monitor.bind(family, FL0)
    episodes, errors = [], []
    for seed in range(20):
        alarms, memory = run(monitor, tabular_stream(family, FL0, FL1, 300, 1300, seed))
        episodes.append(([300], alarms, 1300))
        errors.append(monitor.believed_theta(memory).change_sizes(FL1)[0])
    summary = detection_metrics(episodes)
    assert summary.missed <= 1
    assert summary.mean_delay <= 80
    assert summary.false_alarms_per_1000 <= 2.0
    assert np.median(errors) < 0.1


def test_tabular_cusum_false_alarm_rate_when_stationary():
    """No change in 20 runs of 2,000 steps: at most 2 false alarms per 1,000 steps."""
    family = FrozenLakeFamily()
    monitor = TabularCusumMonitor()
    monitor.bind(family, FL0)
    episodes = [
        ([], run(monitor, tabular_stream(family, FL0, FL0, 0, 2000, seed))[0], 2000)
        for seed in range(20)
    ]
    assert detection_metrics(episodes).false_alarms_per_1000 <= 2.0


def test_impossible_transition_is_a_certain_change():
    """Deterministic CliffWalking: the first slip alarms at that very transition, at any h."""
    family = CliffWalkingFamily()
    theta0 = CliffWalkingParams()  # (1, 0, 0, 0)
    theta1 = CliffWalkingParams(slip=(0.5, 0.5, 0.0, 0.0))
    monitor = TabularCusumMonitor(threshold=1e6)
    monitor.bind(family, theta0)
    memory = monitor.initial_memory()
    rng = np.random.default_rng(0)
    first_slip = None
    for observation in tabular_stream(family, theta0, theta1, 10, 200, seed=1):
        t = int(observation["relative_time"][0]) - 1
        deterministic = family.step(
            observation["last_state"], observation["last_action"], theta0, rng
        )[0]
        flags, sizes = monitor.notify(observation, None, memory, rng)
        if first_slip is None and deterministic != observation["state"]:
            first_slip = t
            assert flags == (1,) and sizes[0] > 0.0
            break
        assert flags == (0,), f"alarm at {t} before any impossible transition"
    assert first_slip is not None and first_slip >= 10
    assert memory.alarms == [first_slip]


def test_tabular_cusum_reset_call_is_no_data():
    """At relative_time 0 (the null action, no transition yet) nothing is updated."""
    family = FrozenLakeFamily()
    monitor = TabularCusumMonitor()
    monitor.bind(family, FL0)
    memory = monitor.initial_memory()
    reset = {**_observation(-1, 0, 0, 0)}
    assert monitor.notify(reset, None, memory, np.random.default_rng(0)) == ((0,), (0.0,))
    assert memory.trace == [] and float(memory.statistics[0].max()) == 0.0


def test_tabular_cusum_checks_its_arguments_and_family():
    """Bad arguments name the parameter; a family without outcome tables is refused."""
    with pytest.raises(ValueError, match="threshold=0"):
        TabularCusumMonitor(threshold=0)
    with pytest.raises(ValueError, match="grid_step=0.3 must divide 1"):
        TabularCusumMonitor(grid_step=0.3)
    with pytest.raises(ValueError, match="change_scale=0"):
        TabularCusumMonitor(change_scale=0)
    with pytest.raises(TypeError, match="no explicit outcome table"):
        TabularCusumMonitor().bind(CartPoleFamily(), CartPoleParams())
    with pytest.raises(RuntimeError, match="TabularCusumMonitor is not bound"):
        TabularCusumMonitor().initial_memory()


def test_a_detector_serves_many_envs_of_one_theta0_only():
    """Same family and θ_0: one instance, independent memories; another θ_0 is refused."""
    monitor = TabularCusumMonitor()
    first = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": FL0.slip}, monitor=monitor)
    second = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": FL0.slip}, monitor=monitor)
    first.reset(seed=0)
    second.reset(seed=1)
    assert first._process.monitor_memory is not second._process.monitor_memory
    with pytest.raises(ValueError, match="give .* its own instance"):
        ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": FL1.slip}, monitor=monitor)


# -- prediction-error CUSUM ------------------------------------------------------------------
def test_prediction_error_detects_a_small_cartpole_change():
    """A pole twice as heavy, from 100 of 300 (10 runs): detected at once, no false alarm.

    The estimate ends within 1% of 0.2 (measured: delay 0, 0 false alarms).
    """
    monitor = PredictionErrorMonitor()
    monitor.bind(CartPoleFamily(), CartPoleParams())
    theta1 = CartPoleParams(masspole=0.2)
    episodes = []
    for seed in range(10):
        alarms, memory = run(monitor, cartpole_stream(CartPoleParams(), theta1, 100, 300, seed))
        episodes.append(([100], alarms, 300))
        assert monitor.believed_theta(memory).masspole == pytest.approx(0.2, rel=0.01)
    summary = detection_metrics(episodes)
    assert summary.missed == 0 and summary.false_alarms == 0
    assert summary.mean_delay <= 1.0


def test_prediction_error_is_silent_when_stationary():
    """θ_0 throughout: rounding to float32 observations stays far below the tolerance."""
    monitor = PredictionErrorMonitor()
    monitor.bind(CartPoleFamily(), CartPoleParams())
    for seed in range(5):
        alarms, memory = run(
            monitor, cartpole_stream(CartPoleParams(), CartPoleParams(), 0, 1000, seed)
        )
        assert alarms == [] and max(memory.trace) == 0.0


def test_prediction_error_checks_its_arguments_and_family():
    """Bad arguments name the parameter; an observation that is not the state is refused."""
    with pytest.raises(ValueError, match="tolerance=-1"):
        PredictionErrorMonitor(tolerance=-1)
    with pytest.raises(ValueError, match="window=0"):
        PredictionErrorMonitor(window=0)
    car = MountainCarContinuousFamily()  # its state holds a flag the observation does not show
    with pytest.raises(TypeError, match="state_from_observation"):
        PredictionErrorMonitor().bind(car, car.default_params())
    with pytest.raises(ValueError, match="probability vector"):
        PredictionErrorMonitor(params=["slip"]).bind(FrozenLakeFamily(), FL0)


# -- through the environments ----------------------------------------------------------------
def _episode_alarms(env, seed: int, policy) -> tuple[list[int], tuple[int, ...], int]:
    observation, _ = env.reset(seed=seed)
    alarms, steps, done = [], 0, False
    while not done:
        observation, _, terminated, truncated, _ = env.step(policy(observation, steps))
        steps += 1
        if observation["env_change"].any():
            alarms.append(int(observation["relative_time"][0]) - 1)
        done = terminated or truncated
    return alarms, env.ground_truth().change_times, steps


@pytest.mark.parametrize(
    ("env_id", "params", "nature", "monitor", "policy", "bound", "false_alarms"),
    [
        (
            "ns_pz/CliffWalking-v0",
            {},
            ScriptedNature(
                {
                    "slip": DistributionStepWiseUpdate(
                        DiscreteScheduler({20}), [(0.4, 0.2, 0.2, 0.2)]
                    )
                }
            ),
            TabularCusumMonitor(),
            lambda obs, t: t % 4,  # walks around near the start without dying at once
            10,
            1,  # a cliff fall told from a wall bump: 4 re-alarms in 40 runs (1 without), 1 here
        ),
        (
            "ns_pz/CartPole-v0",
            {},
            ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({5}), [1.0])}),
            PredictionErrorMonitor(),
            lambda obs, t: int(obs["state"][2] > 0),
            1,
            0,
        ),
        (
            "ns_pz/MountainCar-v0",
            {},
            ScriptedNature({"gravity": StepWiseUpdate(DiscreteScheduler({30}), [0.005])}),
            PredictionErrorMonitor(),
            lambda obs, t: 2 if obs["state"][1] >= 0 else 0,
            1,
            0,
        ),
        (  # the state is read back from cos/sin observations (state_from_observation)
            "ns_pz/Pendulum-v0",
            {},
            ScriptedNature({"mass": StepWiseUpdate(DiscreteScheduler({50}), [1.5])}),
            PredictionErrorMonitor(),
            lambda obs, t: np.array([np.sin(t / 7.0) * 2.0], np.float32),
            1,
            0,
        ),
        (
            "ns_pz/Acrobot-v0",
            {},
            ScriptedNature({"link_mass_2": StepWiseUpdate(DiscreteScheduler({50}), [1.5])}),
            PredictionErrorMonitor(),
            lambda obs, t: (t // 10) % 3,
            1,
            0,
        ),
    ],
    ids=["cliffwalking", "cartpole", "mountaincar", "pendulum", "acrobot"],
)
def test_detectors_through_the_env(env_id, params, nature, monitor, policy, bound, false_alarms):
    """A single change in the Gymnasium view: detected within ``bound`` steps, few false alarms."""
    env = ns_pz.make_gym(
        env_id,
        params=params,
        nature=nature,
        monitor=monitor,
        notification="detailed",
        max_episode_steps=200,
    )
    episodes = [_episode_alarms(env, seed, policy) for seed in range(5)]
    summary = detection_metrics((changes, alarms, steps) for alarms, changes, steps in episodes)
    assert summary.changes == 5 and summary.missed == 0
    assert max(d for e in summary.per_episode for d in e.delays) <= bound
    assert summary.false_alarms <= false_alarms


def test_detailed_alarm_then_refinement_finds_the_parameter():
    """CartPole, masspole 0.1 → 1.0 at transition 1: an alarm at once, flagging one parameter.

    One transition near upright cannot tell a heavier pole from a heavier cart (the first fit
    may pick masscart); later crossings refine silently, and the believed θ ends at the truth.
    """
    monitor = PredictionErrorMonitor()
    env = ns_pz.make_gym(
        "ns_pz/CartPole-v0",
        nature=ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({1}), [1.0])}),
        monitor=monitor,
        notification="detailed",
    )
    observation, _ = env.reset(seed=0)
    alarms = []
    for _ in range(40):
        observation, _, terminated, _, _ = env.step(int(observation["state"][2] > 0))
        if observation["env_change"].any():
            alarms.append(int(observation["relative_time"][0]) - 1)
            assert observation["env_change"].sum() == 1
            assert observation["delta_change"].max() > 0.0
        if terminated:
            break
    assert alarms == [1]
    believed = monitor.believed_theta(env._process.monitor_memory)
    assert believed.masspole == pytest.approx(1.0, rel=1e-3)
    assert believed.masscart == pytest.approx(1.0, rel=1e-3)


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_the_fit_is_the_same_with_and_without_the_batched_kernel():
    """The batched scoring and the scalar one fit the same θ and score alike.

    CartPole transitions under a heavier pole: the batched scoring (one array call per round)
    and the scalar one (a step per value and transition) pick the same value, and their loss
    sums agree (to rounding: they add in other orders), overflows exactly (a NaN sum as
    infinite, an infinite one as the largest float, as ``np.nan_to_num(nan=inf)`` does).
    """
    from ns_pz.monitor.drift import _Scorer

    family = CartPoleFamily()
    theta0 = CartPoleParams()
    heavy = theta0.replace(masspole=1.0)
    monitor = PredictionErrorMonitor()
    monitor.bind(family, theta0)
    rng = np.random.default_rng(0)
    state = family.initial_state(rng)
    data = []
    for t in range(6):
        action = t % 2
        after, _, _ = family.step(state, action, heavy, rng)
        data.append((state, action, np.asarray(family.observe(after), np.float64)))
        state = after
    fast = (0.0, 2e40, 0.0, 0.0)  # its next x overflows the float32 observation
    overflowing = [*data, (fast, 0, np.zeros(4))]
    unexplained = [*data, (state, 0, np.full(4, np.nan))]
    columns = np.array([monitor._columns["masspole"]] * 2 + [monitor._columns["length"]] * 2)
    values = np.array([0.1, 1.0, 0.5, 2.0])

    def scored() -> tuple[object, ...]:
        return (
            monitor._estimate(theta0, data, rng),
            *(
                _Scorer(monitor, theta0, d, rng).losses(columns, values)
                for d in (data, overflowing, unexplained)
            ),
        )

    batched = scored()
    kernel, monitor._kernel = monitor._kernel, None
    try:
        scalar = scored()
    finally:
        monitor._kernel = kernel
    assert kernel is not None
    assert batched[0] == scalar[0] and batched[0].masspole == pytest.approx(1.0, rel=1e-3)
    np.testing.assert_allclose(batched[1], scalar[1], rtol=1e-12)
    for fast_sums, slow_sums in zip(batched[2:], scalar[2:], strict=True):
        np.testing.assert_array_equal(fast_sums, slow_sums)
    assert (batched[2] == np.finfo(np.float64).max).all() and np.isinf(batched[3]).all()


def test_zoom_grids_are_numpys_linspace():
    """Every row of the refinement's grids is ``np.linspace(low, high, points)`` bit for bit.

    Brackets of zero width and of subnormal width included.
    """
    from ns_pz.monitor.drift import _linspaces

    rng = np.random.default_rng(1)
    lows = rng.normal(size=2000) * 10.0 ** rng.uniform(-5, 5, 2000)
    widths = np.abs(rng.normal(size=2000)) * 10.0 ** rng.uniform(-8, 3, 2000)
    lows = np.concatenate([lows, rng.uniform(0, 1e-310, 10), [2.5, -0.0]])
    widths = np.concatenate([widths, rng.integers(0, 9, 10) * 5e-324, [0, 0]])
    brackets = np.stack([lows, lows + widths], axis=1)
    for points in (17, 10):  # 10: a step of a ninth, whose multiples miss high
        expected = np.array([np.linspace(low, high, points) for low, high in brackets])
        assert np.array_equal(_linspaces(brackets, points).view(np.int64), expected.view(np.int64))


# -- noisy oracle ----------------------------------------------------------------------------
def _oracle_run(monitor, changes: set[int], steps: int, seed: int) -> list[int]:
    memory = monitor.initial_memory()
    rng = np.random.default_rng(seed)
    for t in range(steps):
        truth = (0.3,) if t in changes else (0.0,)
        monitor.notify(_observation(t, 0, 0, 0), truth, memory, rng)
    return memory.alarms


def test_noisy_oracle_delay_misses_and_false_alarms():
    """Exact delays; miss and false-alarm frequencies near their probabilities; seeded."""
    exact = NoisyOracleMonitor(delay=3)
    assert _oracle_run(exact, {5, 40}, 100, seed=0) == [8, 43]
    missing = NoisyOracleMonitor(miss_probability=0.3)
    detected = sum(len(_oracle_run(missing, {5}, 10, seed)) for seed in range(2000))
    assert 0.66 < detected / 2000 < 0.74  # 0.7, about 5 standard errors either side
    noisy = NoisyOracleMonitor(false_alarm_probability=0.02)
    alarms = sum(len(_oracle_run(noisy, set(), 1000, seed)) for seed in range(20))
    assert 15.0 < alarms / 20 < 25.0  # 20 expected per 1,000 steps
    assert _oracle_run(noisy, set(), 1000, 7) == _oracle_run(noisy, set(), 1000, 7)


def test_noisy_oracle_checks_its_arguments():
    """Bad probabilities and delays name the parameter."""
    with pytest.raises(ValueError, match="miss_probability=1.5"):
        NoisyOracleMonitor(miss_probability=1.5)
    with pytest.raises(TypeError, match="delay=1.5"):
        NoisyOracleMonitor(delay=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="delay=-1"):
        NoisyOracleMonitor(delay=-1)


def test_delayed_oracle_through_the_env():
    """In the view, a change at 3 reported with delay 2 alarms at 5."""
    env = ns_pz.make_gym(
        "ns_pz/CartPole-v0",
        nature=ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({3}), [0.5])}),
        monitor=NoisyOracleMonitor(delay=2),
        notification="detailed",
    )
    alarms, changes, _ = _episode_alarms(env, 0, lambda obs, t: int(obs["state"][2] > 0))
    assert changes == (3,) and alarms == [5]


def test_planning_model_follows_the_detector_not_the_truth():
    """A detector that has not alarmed yet leaves the planner at θ_0 (WD is honest)."""
    env = ns_pz.make_gym(
        "ns_pz/FrozenLake-v0",
        params={"slip": (0.7, 0.15, 0.15)},
        nature=ScriptedNature(
            {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [(0.4, 0.3, 0.3)])}
        ),
        monitor=TabularCusumMonitor(threshold=1e6),
        notification="detailed",
    )
    env.reset(seed=0)
    env.step(1)
    env.step(1)  # transition 1 ran under the new θ; the detector cannot know yet
    assert env.planning_model().theta.slip == (0.7, 0.15, 0.15)


def _slip_change_at(step: int) -> ScriptedNature:
    update = DistributionStepWiseUpdate(
        DiscreteScheduler([step]), update_values=[(0.1, 0.45, 0.45)]
    )
    return ScriptedNature({"slip": update})


def test_a_noisy_oracle_never_leaks_a_missed_change_through_a_later_report():
    """Only reported parameters reach the planner, at their values of the latest report.

    A later report of a parameter carries its value then; a missed change to another parameter
    stays unknown.
    """
    nature = ScriptedNature(
        {
            "masspole": StepWiseUpdate(DiscreteScheduler([1, 2]), [0.2, 0.3]),
            "length": StepWiseUpdate(DiscreteScheduler([3]), [0.6]),
        }
    )
    for seed in range(40):
        env = ns_pz.make_gym(
            "ns_pz/CartPole-v0",
            nature=nature,
            monitor=NoisyOracleMonitor(miss_probability=0.5),
            notification="detailed",
        )
        env.reset(seed=seed)
        told: dict[str, float] = {}
        names = env.unwrapped.process.param_names
        truth = env.unwrapped.process
        for _ in range(6):
            obs, *_ = env.step(0)
            for i in np.flatnonzero(obs["env_change"]):
                # the value after the reported change is what the planner may know of it
                told[names[i]] = getattr(truth.theta_at(truth.t - 1), names[i])
            planned = env.planning_model().theta
            for name in ("masspole", "length"):
                expected = told.get(name, getattr(truth.theta0, name))
                assert getattr(planned, name) == expected, (seed, name)


@pytest.mark.parametrize(
    ("monitor", "told_at"),
    [
        (NoisyOracleMonitor(miss_probability=1.0), None),  # never told: θ_0 throughout
        (NoisyOracleMonitor(delay=3), 5),  # the change of transition 1, reported 3 later
        (NoisyOracleMonitor(), 2),  # the oracle's timing
    ],
)
def test_a_noisy_oracle_never_hands_the_planner_a_change_it_has_not_reported(monitor, told_at):
    """At detailed the planner gets the θ the agent has been told of, not the truth."""
    env = ns_pz.make_gym(
        "ns_pz/FrozenLake-v0",
        params={"slip": (1.0, 0.0, 0.0)},
        nature=_slip_change_at(1),
        monitor=monitor,
        notification="detailed",
    )
    env.reset(seed=0)
    for t in range(1, 8):
        obs, *_ = env.step(0)
        told = told_at is not None and t >= told_at
        expected = (0.1, 0.45, 0.45) if told else (1.0, 0.0, 0.0)
        assert env.planning_model().theta.slip == expected, t
        assert env.get_planning_env().process.theta.slip == expected, t
        assert bool(obs["env_change"][0]) == (t == told_at), t


def test_a_tabular_detector_refuses_an_episode_from_another_theta0():
    """Its outcome tables are θ_0's: another θ_0 in reset options is refused, the same kept."""
    env = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0",
        monitor=TabularCusumMonitor(),
        notification="detailed",
        params={"slip": (0.7, 0.1, 0.1, 0.1)},
    )
    with pytest.raises(ValueError, match="bound to θ_0"):
        env.reset(seed=0, options={"params": {"slip": (1.0, 0.0, 0.0, 0.0)}})
    env.reset(seed=0, options={"params": {"slip": (0.7, 0.1, 0.1, 0.1)}})
    oracle = ns_pz.make_gym("ns_pz/CartPole-v0", notification="detailed")
    oracle.reset(seed=0, options={"params": {"masspole": 0.3}})  # the oracle needs no reference


def test_the_prediction_error_detector_predicts_from_the_episodes_theta0():
    """Its reference is a θ in its memory: an episode's own θ_0 gives no false alarm."""
    cart = ns_pz.make_gym(
        "ns_pz/CartPole-v0", monitor=PredictionErrorMonitor(), notification="detailed"
    )
    cart.reset(seed=0, options={"params": {"masspole": 0.3}})
    assert cart.planning_model().theta.masspole == 0.3
    assert cart.planning_model().theta.masspole == 0.3
    alarms = 0
    for step in range(40):
        obs, _, terminated, truncated, _ = cart.step(step % 2)
        alarms += int(obs["env_change"].any())
        if terminated or truncated:
            break
    assert alarms == 0


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: TabularCusumMonitor(params="slip"), "list of parameter names"),
        (lambda: TabularCusumMonitor(params=[]), "watches nothing"),
        (lambda: TabularCusumMonitor(threshold=True), "threshold=True"),
        (lambda: PredictionErrorMonitor(params="masspole"), "list of parameter names"),
        (lambda: PredictionErrorMonitor(threshold=True), "threshold=True"),
        (lambda: PredictionErrorMonitor(factors="12"), "factors='12'"),
        (lambda: PredictionErrorMonitor(factors=[0.5, -1.0]), r"factors\[...\]=-1.0"),
        (lambda: PredictionErrorMonitor(params=3), "params=3 must be a list"),
        (lambda: TabularCusumMonitor(change_scale="big"), "change_scale='big' must be a finite"),
    ],
)
def test_detector_arguments_are_checked_by_name(make, match):
    """A bare string, an empty list, a bool threshold: refused when the detector is built."""
    with pytest.raises((TypeError, ValueError), match=match):
        make()


def test_prediction_error_refuses_noisy_dynamics():
    """Acrobot with torque noise would alarm at every transition: refused when bound."""
    with pytest.raises(ValueError, match="draws from its generator"):
        ns_pz.make_gym(
            "ns_pz/Acrobot-v0",
            torque_noise_max=0.1,
            monitor=PredictionErrorMonitor(),
            notification="detailed",
        )
    ns_pz.make_gym("ns_pz/Acrobot-v0", monitor=PredictionErrorMonitor(), notification="detailed")


def test_scoring_and_numpy_counts_take_integers_and_name_the_rest():
    """NaN or strings as times, a string λ: named; NumPy integers count as ints."""
    from ns_pz.monitor import detection_reward

    with pytest.raises(ValueError, match="must hold integers"):
        score_episode([float("nan")], [], 5)
    with pytest.raises(ValueError, match="must hold integers"):
        score_episode(["a"], [], 5)
    with pytest.raises(ValueError, match="false_alarm_cost='10'"):
        detection_reward(True, False, "10")
    assert score_episode([1], [2], np.int64(5)).delays == (1,)
    assert NoisyOracleMonitor(delay=np.int64(2)).delay == 2
    env = ns_pz.make_gym("ns_pz/CartPole-v0", max_episode_steps=np.int64(3))
    env.reset(seed=0)
    assert [env.step(0)[3] for _ in range(3)] == [False, False, True]


def test_detectors_take_generators_and_numpy_counts():
    """A generator of names is read once; NumPy integers are ints."""
    watched = PredictionErrorMonitor(params=(name for name in ["masspole"]), window=np.int64(5))
    assert watched.watched == ("masspole",) and watched.window == 5
    assert TabularCusumMonitor(threshold=np.int64(7)).threshold == 7.0


def test_an_alarm_at_reset_is_a_false_alarm_for_both_scorings():
    """α = -1 (flag on the reset observation) is scored, as DetectionReward scores it."""
    from ns_pz import DECISION, MONITOR

    assert score_episode([3], [-1, 3], 10).false_alarms == 1
    with pytest.raises(ValueError, match=r"must lie in \[-1, steps\)"):
        score_episode([], [-2], 10)
    with pytest.raises(ValueError, match=r"must lie in \[0, steps\)"):
        score_episode([-1], [], 10)
    seat = ns_pz.single_agent(
        "ns_pz/CartPole-v0",
        MONITOR,
        {DECISION: lambda obs: 0},
        monitor_reward=ns_pz.monitor.DetectionReward(1.0),
        notification="basic",
        max_episode_steps=5,
    )
    seat.reset(seed=0)
    total, steps, done = 0.0, 0, False
    while not done:
        _, reward, terminated, truncated, _ = seat.step(np.ones(6, np.int64))
        total += reward
        steps += 1
        done = terminated or truncated
    alarms = list(range(-1, steps - 1))  # every monitor turn flags: about transitions -1 ..
    assert score_episode([], alarms, steps).false_alarms == -total == steps


def test_tabular_cusum_after_two_parameters_changed_compares_each_with_the_others_estimate():
    """BridgeSplit, both slips 0.9 → 0.5 one after the other: two alarms, beliefs near 0.5.

    Each grid kept the other parameter at θ_0, so once both had changed the CUSUMs alarmed in
    turn forever (8 false alarms per 1,000 steps) and a belief could end at 0.25.
    """
    from ns_pz.agents.exact import equal_split
    from ns_pz.envs.bridge import SplitBridgeFamily, SplitBridgeParams

    family = SplitBridgeFamily()
    before, after = equal_split(0.9, 3), equal_split(0.5, 3)
    thetas = [
        SplitBridgeParams(slip_left=before, slip_right=before),
        SplitBridgeParams(slip_left=after, slip_right=before),
        SplitBridgeParams(slip_left=after, slip_right=after),
    ]
    tables = [family.outcomes(theta) for theta in thetas]
    live = [s for s in range(tables[0].probs.shape[0]) if not family.is_terminal_state(s)]
    monitor = TabularCusumMonitor(threshold=10.0)
    monitor.bind(family, thetas[0])
    episodes = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        memory = monitor.initial_memory()
        alarms = []
        for t in range(800):
            table = tables[0 if t < 50 else 1 if t < 300 else 2]
            state, action = int(rng.choice(live)), int(rng.integers(4))
            outcome = rng.choice(3, p=table.probs[state, action])
            observation = {
                "last_state": state,
                "last_action": action,
                "last_reward": np.array([table.rewards[state, action, outcome]], np.float32),
                "state": int(table.next_states[state, action, outcome]),
                "relative_time": np.array([t + 1.0]),
            }
            flags, _ = monitor.notify(observation, None, memory, rng)
            if any(flags):
                alarms.append(t)
        episodes.append(((50, 300), alarms, 800))
        believed = monitor.believed_theta(memory)
        assert abs(believed.slip_left[0] - 0.5) < 0.1
        assert abs(believed.slip_right[0] - 0.5) < 0.1
    summary = detection_metrics(episodes)
    assert summary.detected == 8
    assert summary.false_alarms <= 2


# -- the belief a first alarm reports --------------------------------------------------------
FROZEN = FrozenLakeParams(slip=(1.0, 0.0, 0.0))


def _brute_force_belief(family, monitor, transitions) -> np.ndarray:
    """Posterior mean slip vector over every (change time, grid point), written out.

    Prior: the change's size (total variation from θ_0) exponential with mean
    ``monitor.change_scale``, equal among the grid points of one size; change time uniform
    over the transitions; before it θ_0's kernel, from it the grid point's.
    """
    units = round(1 / monitor.grid_step)
    points = [
        (a / units, b / units, (units - a - b) / units)
        for a in range(units + 1)
        for b in range(units + 1 - a)
    ]
    size = [
        round(units * 0.5 * sum(abs(p - q) for p, q in zip(g, FROZEN.slip, strict=True)))
        for g in points
    ]
    members = {s: size.count(s) for s in size}

    def chance(theta, state, action, reached):
        table = family.outcomes(theta)
        return table.probs[state, action][table.next_states[state, action] == reached].sum()

    mean, total = np.zeros(3), 0.0
    for g, s in zip(points, size, strict=True):
        prior = np.exp(-(s / units) / monitor.change_scale) / members[s]
        theta = FrozenLakeParams(slip=g)
        for change in range(len(transitions)):
            weight = prior
            for t, transition in enumerate(transitions):
                weight *= chance(theta if t >= change else FROZEN, *transition)
            mean += weight * np.array(g)
            total += weight
    return mean / total


@pytest.mark.parametrize(
    "transitions",
    [
        [(9, 2, 10), (10, 2, 14)],  # one intended move (right), then a slip (down)
        [(10, 2, 14)],  # a slip at transition 0
        [(9, 2, 10), (0, 1, 4), (10, 2, 14)],  # two intended moves, then the slip
    ],
)
def test_the_first_alarm_believes_the_joint_posterior_over_change_time_and_theta(transitions):
    """Deterministic lake: the alarm at the first slip reports the written-out posterior.

    The segment posterior used to start at the CUSUM's last zero, the slip alone under a
    uniform prior: one intended move then one slip gave (0.238, 0.525, 0.238), a reported change
    of 0.76; a slip at transition 0 gave the uniform prior's mean (1/3 each).
    """
    family = FrozenLakeFamily()
    monitor = TabularCusumMonitor()
    monitor.bind(family, FROZEN)
    memory = monitor.initial_memory()
    rng = np.random.default_rng(0)
    for t, (state, action, reached) in enumerate(transitions):
        flags, sizes = monitor.notify(_observation(t, state, action, reached), None, memory, rng)
        assert flags == ((1,) if t == len(transitions) - 1 else (0,))
    believed = np.array(monitor.believed_theta(memory).slip)
    expected = _brute_force_belief(family, monitor, transitions)
    np.testing.assert_allclose(believed, expected, atol=1e-6)
    assert believed[0] > 0.6  # a small change is believed likelier than a large one
    assert sizes[0] == pytest.approx(1.0 - believed[0], abs=1e-6)


def test_the_first_alarm_belief_on_cliffwalking_is_near_the_truth():
    """CliffWalking 1.0 → 0.8 at transition 1, a random walker, 100 runs.

    Median p(intended) believed at the first alarm: measured 0.70 (it was 0.19 in every run
    with the last-zero window under a uniform prior). Bound: within 0.15 of 0.8.
    """
    from ns_pz.agents.exact import equal_split

    nature = ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [equal_split(0.8, 4)])}
    )
    env = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0",
        monitor=TabularCusumMonitor(),
        nature=nature,
        notification="detailed",
        max_episode_steps=200,
    )
    beliefs = []
    for seed in range(100):
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for _ in range(200):
            observation, *_ = env.step(int(rng.integers(4)))
            if observation["env_change"][0]:
                beliefs.append(env.unwrapped.process.planning_theta().slip[0])
                break
    assert len(beliefs) >= 95
    assert abs(np.median(beliefs) - 0.8) < 0.15


def test_the_reward_tells_a_cliff_fall_from_a_wall_bump():
    """From the start, UP under (0.5, 0, 0.5, 0): a wall bump (-1) is possible, a fall is not.

    Both end on the start; keyed on the next state alone the fall looked as likely as the bump.
    """
    family = CliffWalkingFamily()
    monitor = TabularCusumMonitor(threshold=1e6)
    monitor.bind(family, CliffWalkingParams(slip=(0.5, 0.0, 0.5, 0.0)))
    rng = np.random.default_rng(0)
    for reward, alarm in ((-1.0, (0,)), (-100.0, (1,))):
        observation = {**_observation(0, 36, 0, 36), "last_reward": np.array([reward], np.float32)}
        assert monitor.notify(observation, None, monitor.initial_memory(), rng)[0] == alarm


def test_a_grid_too_fine_for_memory_is_refused_with_its_size():
    """grid_step=0.001 over 4 outcomes is 167,668,501 points: terabytes of outcome tables."""
    with pytest.raises(ValueError, match=r"grid_step=0.001 gives 167,668,501 grid points .* GiB"):
        TabularCusumMonitor(grid_step=0.001).bind(CliffWalkingFamily(), CliffWalkingParams())


def test_a_nan_prediction_error_is_an_alarm():
    """A NaN observation cannot be predicted: the CUSUM alarms (it used to restart at 0)."""
    family = CartPoleFamily()
    monitor = PredictionErrorMonitor()
    monitor.bind(family, CartPoleParams())
    memory = monitor.initial_memory()
    state = np.zeros(4, np.float32)
    broken = np.array([0.0, np.nan, 0.0, 0.0], np.float32)
    observation = _observation(0, state, 0, broken)
    flags, _ = monitor.notify(observation, None, memory, np.random.default_rng(0))
    assert any(flags) and memory.alarms == [0]


def test_false_alarms_before_the_first_change_are_told_from_re_alarms():
    """Pre-change false alarms (ARL₀'s) and post-change ones are counted apart; delay quantiles.

    Before, one ``false_alarms`` mixed them: with the change at step 1 of the shipped specs,
    nearly every reported false alarm was a re-alarm after the detection.
    """
    episode = score_episode([5], [-1, 2, 5, 7, 9], 20)
    assert (episode.pre_change_steps, episode.pre_change_false_alarms) == (5, 2)
    assert episode.post_change_false_alarms == 2 and episode.false_alarms == 4
    quiet = score_episode([], [3], 10)
    assert (quiet.pre_change_steps, quiet.pre_change_false_alarms) == (10, 1)
    delays = [0, 0, 1, 2, 3, 4, 5, 6, 7, 30]
    summary = detection_metrics([([1], [1 + d, 60], 100) for d in delays] + [([], [3], 10)])
    assert summary.mean_delay == pytest.approx(5.8)
    assert summary.median_delay == 3.5 and summary.p90_delay == pytest.approx(9.3)
    assert (summary.pre_change_steps, summary.pre_change_false_alarms) == (20, 1)
    assert summary.post_change_false_alarms == 10
    assert summary.pre_change_false_alarms_per_1000 == pytest.approx(50.0)
    assert math.isnan(detection_metrics([([], [], 5)]).median_delay)
