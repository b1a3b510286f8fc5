"""Planning models: save/restore, agreement with the outcome table, independence."""

from __future__ import annotations

import math
import re
from typing import Any

import gymnasium
import numpy as np
import pytest
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

import ns_pz
from ns_pz.planning import TabularModel


def test_save_restore_replays_the_same_transition_given_the_same_draw():
    """Restoring a saved state and redrawing with the same generator state repeats the outcome."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    saved = model.get_state()
    first = model.step(1)
    model.set_state(saved)
    assert model.step(1) == first
    assert model.get_state() == first[0]


def test_sampled_frequencies_match_the_outcome_table():
    """Sampling a tabular model reproduces the probabilities of its explicit table."""
    family = FrozenLakeFamily("4x4")
    theta = FrozenLakeParams(slip=(0.5, 0.3, 0.2))
    model = family.planning_model(theta, 5 - 5, np.random.default_rng(0))
    assert isinstance(model, TabularModel)
    counts: dict = {}
    draws = 20_000
    for _ in range(draws):
        nxt, _, _ = model.transition(0, 2)
        counts[nxt] = counts.get(nxt, 0) + 1
    table = model.outcomes
    expected: dict = {}
    for k in range(3):
        nxt = int(table.next_states[0, 2, k])
        expected[nxt] = expected.get(nxt, 0.0) + table.probs[0, 2, k]
    for nxt, prob in expected.items():
        assert abs(counts[nxt] / draws - prob) < 0.015


def test_clone_is_independent_in_state():
    """A clone moves on its own; the original keeps its state."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    env.reset(seed=0)
    model = env.planning_model()
    clone = model.clone()
    clone.step(2)
    assert model.get_state() == 0
    assert clone.theta is model.theta


def test_terminal_cells_absorb():
    """From a hole or the goal every outcome stays put, terminal, with no reward."""
    family = FrozenLakeFamily("4x4")
    table = family.outcomes(FrozenLakeParams())
    for cell in (5, 15):
        assert (table.next_states[cell] == cell).all() and table.terminals[cell].all()
        assert not table.rewards[cell].any()


# -- validation at the public set_state / step (issue 9, item 8) --------------------------------
_BAD_STATES = [-1, 10**6, None, True, 1.5, "0", (math.nan,) * 4, (math.nan,) * 2, (math.inf, 0.0)]
_BAD_ACTIONS = [5, -1, None, 1.5, True, [math.nan], "1"]


@pytest.mark.parametrize("env_id", ns_pz.registered_envs())
def test_every_planning_model_refuses_garbage_states_and_actions(env_id):
    """set_state and step refuse what is not a state or an action, naming it; valid ones pass."""
    env = ns_pz.make_gym(env_id)
    env.reset(seed=0)
    model = env.planning_model()
    start = model.get_state()
    model.set_state(start)
    for bad in _BAD_STATES:
        with pytest.raises(ValueError, match=re.escape(f"state={bad!r}")):
            model.set_state(bad)
        assert model.get_state() == start
    for bad in _BAD_ACTIONS:
        with pytest.raises(ValueError, match=re.escape(f"action={bad!r}")):
            model.step(bad)
        assert model.get_state() == start
    model.step(env.action_space.sample())


def test_cartpole_model_refuses_actions_it_used_to_read_as_zero():
    """Actions 5, -1 and None used to push left like action 0."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    for bad in (5, -1, None):
        with pytest.raises(ValueError, match=rf"action={bad!r} is outside the action space"):
            model.step(bad)


def test_frozen_lake_model_refuses_a_negative_cell():
    """set_state(-1) used to index from the end: step(1) then returned cell 15, the goal."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    env.reset(seed=0)
    model = env.planning_model()
    with pytest.raises(ValueError, match=r"state=-1 .*allowed: an int in \[0, 16\)"):
        model.set_state(-1)
    model.set_state(np.int64(14))
    assert type(model.get_state()) is int


def test_physical_models_refuse_non_finite_and_out_of_bounds_states():
    """NaN anywhere, a wrong length and a velocity the dynamics never reach are refused."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    with pytest.raises(ValueError, match=r"x=nan is not finite"):
        model.set_state((math.nan,) * 4)
    with pytest.raises(ValueError, match=r"has 3 entries; allowed: a tuple of 4 finite floats"):
        model.set_state((0.0, 0.0, 0.0))
    model.set_state(np.array([0.1, 0.0, -0.1, 0.0]))  # an array is accepted and stored as floats
    assert model.get_state() == (0.1, 0.0, -0.1, 0.0)
    pendulum = ns_pz.make_gym("ns_pz/Pendulum-v0")
    pendulum.reset(seed=0)
    with pytest.raises(ValueError, match=r"angular_velocity=9.0 is outside \[-8.0, 8.0\]"):
        pendulum.planning_model().set_state((0.0, 9.0))
    cliff = ns_pz.make_gym("ns_pz/CliffWalking-v0")
    cliff.reset(seed=0)
    with pytest.raises(ValueError, match=r"state=40 is a cliff cell"):
        cliff.planning_model().set_state(40)


def test_outcome_table_model_refuses_garbage_too():
    """The model over a hand-built table checks set_state and step like the families' models."""
    from ns_pz.agents.search.table_model import OutcomeTableModel

    family = FrozenLakeFamily("4x4")
    model = OutcomeTableModel(family.outcomes(FrozenLakeParams()), 0, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"state=-1 .*\[0, 16\)"):
        model.set_state(-1)
    with pytest.raises(ValueError, match=r"action=4 is outside"):
        model.step(4)
    model.set_state(np.int32(3))
    assert model.step(np.int64(0))[0] in range(16)


def _flags_in(env: Any, steps: int, rng: np.random.Generator, resets: bool = True) -> int:
    """Steps whose observation flags a change, under random actions (resetting at the ends)."""
    flagged = 0
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(int(rng.integers(env.action_space.n)))
        flagged += int(obs["env_change"].any())
        if terminated or truncated:
            if not resets:
                break
            env.reset()
    return flagged


@pytest.mark.parametrize(
    ("env_id", "changes", "params", "detector"),
    [
        (
            "ns_pz/FrozenLake-v0",
            {"slip": (0.2, 0.4, 0.4)},
            {"slip": (1.0, 0.0, 0.0)},
            lambda: ns_pz.monitor.TabularCusumMonitor(threshold=10.0),
        ),
        (
            "ns_pz/CartPole-v0",
            {"length": 2.0, "force_mag": 20.0},
            {},
            lambda: ns_pz.monitor.PredictionErrorMonitor(),
        ),
    ],
)
def test_a_planning_copy_goes_on_with_what_its_detector_knows(
    env_id: str, changes: dict, params: dict, detector: Any
) -> None:
    """A copy's detector goes on from what the agent's detector knows.

    In a stationary copy made after a detection, it reports nothing (it compared the copy's
    world with the original θ_0 and flagged 12% of FrozenLake's steps); the copy's own episodes
    (its resets) start from what the detector knew.
    """
    from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate
    from ns_pz.nature.distribution_updates import DistributionStepWiseUpdate

    rules = {
        name: (DistributionStepWiseUpdate if isinstance(value, tuple) else StepWiseUpdate)(
            DiscreteScheduler([1]), [value]
        )
        for name, value in changes.items()
    }
    env = gymnasium.make(
        env_id,
        params=params,
        nature=ScriptedNature(rules),
        monitor=detector(),
        notification="detailed",
        max_episode_steps=1000,
    ).unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        obs, *_ = env.step(int(rng.integers(env.action_space.n)))
        if obs["env_change"].any():
            break
    else:
        pytest.fail("the detector did not detect the change")
    copy = env.get_planning_env()
    believed = env.process.planning_theta()
    assert copy.process.theta == believed != env.process.theta0
    assert copy.process.planning_theta() == believed  # it knows what the detector knew
    assert _flags_in(copy, 600, rng) == 0
    assert env.process.planning_theta() == believed  # the copy's detector is its own
    kept = env.branch(keep_nature=True)  # nature's one change is behind: no change this episode
    assert _flags_in(kept, 300, rng, resets=False) == 0
    assert kept.process.change_times == []
    # The belief, not the episode's timeline (a deep copy cost O(t) per copy: 2.8 ms at t=400).
    memory = env.get_planning_env().process.monitor_memory
    assert memory.trace == [] and memory.alarms == []
    assert env.process.monitor_memory.trace  # the original keeps its own


def test_a_planning_copy_hears_nothing_of_the_originals_pending_reports():
    """A NoisyOracle's delayed report of the original's change is not the copy's to make."""
    from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate

    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler([2]), [0.3])})
    env = gymnasium.make(
        "ns_pz/CartPole-v0",
        nature=nature,
        monitor=ns_pz.monitor.NoisyOracleMonitor(delay=5),
        notification="detailed",
        max_episode_steps=100,
    ).unwrapped
    env.reset(seed=0)
    for t in range(4):
        env.step(t % 2)
    assert env.process.monitor_memory.pending  # reported at step 7, after the copy is made
    copy = env.get_planning_env()
    assert _flags_in(copy, 8, np.random.default_rng(0), resets=False) == 0
    assert sum(bool(env.step(t % 2)[0]["env_change"].any()) for t in range(6)) == 1


class _CountingAlarm(ns_pz.monitor.Monitor):
    """A monitor of our own with memory: alarms once, three transitions in."""

    def initial_memory(self) -> dict:
        return {"seen": 0}

    def notify(self, observation: Any, truth: Any, memory: dict, rng: Any) -> tuple:
        quiet = (0,) * 6, (0.0,) * 6
        if observation["relative_time"][0] == 0:
            return quiet
        memory["seen"] += 1
        return ((0, 0, 1, 0, 0, 0), (0.0,) * 6) if memory["seen"] == 3 else quiet


def test_a_planning_copy_keeps_the_memory_of_a_monitor_of_ones_own():
    """A memoryful monitor that is neither an oracle nor a Detector knows what it knew."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0", monitor=_CountingAlarm(), notification="basic")
    env.reset(seed=0)
    for _ in range(4):
        env.step(0)
    copy = env.get_planning_env()
    assert copy.process.monitor_memory == {"seen": 4}
    assert not any(copy.step(0)[0]["env_change"].any() for _ in range(3))


@pytest.mark.parametrize("level", ["basic", "detailed"])
def test_a_copy_at_another_theta_than_the_detector_believes_rebases_it(level):
    """A detector whose belief is not the copy's θ is re-based on the copy's θ.

    Below detailed the copy is at θ_0 while the detector believes the new θ (and so does
    branch(theta=θ_0)): it flagged 17 of 300 steps in a world that never changes.
    """
    from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate

    env = gymnasium.make(
        "ns_pz/CartPole-v0",
        nature=ScriptedNature({"length": StepWiseUpdate(DiscreteScheduler([1]), [2.0])}),
        monitor=ns_pz.monitor.PredictionErrorMonitor(),
        notification=level,
        max_episode_steps=1000,
    ).unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        if env.step(int(rng.integers(2)))[0]["env_change"].any():
            break
    assert env.process.monitor_memory.reference != env.process.theta0  # it believes a change
    for copy in (env.get_planning_env(), env.branch(theta=env.process.theta0)):
        assert _flags_in(copy, 300, np.random.default_rng(1)) == 0
