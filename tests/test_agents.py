"""The first agents: the random baseline and the two planners over the handed model."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import RandomAgent, RandomShooting, SnapshotValueIteration, value_iteration
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

import ns_pz


def test_value_iteration_on_a_deterministic_lake_finds_the_shortest_path():
    """With no slip the value of the start is gamma^(steps to goal - 1)."""
    outcomes = FrozenLakeFamily("4x4").outcomes(FrozenLakeParams(slip=(1.0, 0.0, 0.0)))
    values, q_values = value_iteration(outcomes, gamma=0.9)
    assert values[0] == pytest.approx(0.9**5)  # six moves from (0, 0) to (3, 3)
    assert values[15] == 0.0 and q_values.shape == (16, 4)


def test_one_value_iteration_agent_serves_different_maps():
    """The policy cache is keyed by family and θ, so a 4x4 policy never answers for the 8x8."""
    shared = SnapshotValueIteration()
    shared.reset(np.random.default_rng(0))
    theta = {"slip": (1.0, 0.0, 0.0)}
    small = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=theta)
    obs, _ = small.reset(seed=0)
    shared.act(obs, small.planning_model())
    large = ns_pz.make_gym("ns_pz/FrozenLake8x8-v0", params=theta)
    obs, _ = large.reset(seed=0)
    model = large.planning_model()
    model.set_state(62)  # next to the 8x8 goal: moving RIGHT wins
    fresh = SnapshotValueIteration()
    fresh.reset(np.random.default_rng(0))
    assert shared.act(obs, model) == fresh.act(obs, model) == 2


def test_agents_are_reproducible_from_their_generator():
    """Same generator seed, same actions."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    obs, _ = env.reset(seed=0)
    for agent in (RandomAgent(env.action_space), RandomShooting(num_rollouts=2, depth=5)):
        actions = []
        for _ in range(2):
            agent.reset(np.random.default_rng(7))
            actions.append([agent.act(obs, env.planning_model()) for _ in range(5)])
        assert actions[0] == actions[1]


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: RandomShooting(gamma=5.0), "gamma=5.0"),
        (lambda: RandomShooting(gamma=-1.0), "gamma=-1.0"),
        (lambda: RandomShooting(depth=2.5), "depth=2.5"),
        (lambda: SnapshotValueIteration(gamma=False), "gamma=False"),
        (lambda: SnapshotValueIteration(cache_size=2.5), "cache_size=2.5"),
        (lambda: SnapshotValueIteration(cache_size=True), "cache_size=True"),
        (lambda: RandomShooting(num_rollouts=0), "num_rollouts=0"),
    ],
)
def test_planner_arguments_are_checked_by_name(make, match):
    """Discounts are real numbers in range (a bool is none), counts are ints."""
    with pytest.raises((TypeError, ValueError), match=match):
        make()


def test_run_episode_takes_a_gym_make_stack():
    """gym.make wraps the view; the episode runs through the wrappers, planning on the view."""
    import gymnasium as gym
    from ns_pz.agents.evaluation import run_episode

    wrapped = run_episode(gym.make("ns_pz/FrozenLake-v0"), SnapshotValueIteration(), 0)
    bare = run_episode(ns_pz.make_gym("ns_pz/FrozenLake-v0"), SnapshotValueIteration(), 0)
    assert (wrapped.episode_return, wrapped.length) == (bare.episode_return, bare.length)
    with pytest.raises(TypeError, match="must be an ns_pz view"):
        run_episode(gym.make("FrozenLake-v1"), SnapshotValueIteration(), 0)


def test_planner_counts_take_numpy_integers():
    """Counts from a NumPy sweep are ints."""
    assert RandomShooting(depth=np.int64(3)).depth == 3
    assert SnapshotValueIteration(cache_size=np.int64(4)).cache_size == 4
