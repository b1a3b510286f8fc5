"""CliffWalking and Bridge: Gymnasium-equal dynamics, paper rewards, slip orientation, maps."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from ns_pz.envs.bridge import BridgeFamily, SplitBridgeFamily
from ns_pz.envs.cliff_walking import CliffWalkingFamily

import ns_pz


def test_cliff_walking_matches_gymnasium_step_for_step():
    """Deterministic θ, same seed and actions: Gymnasium's CliffWalking-v1, cliff falls too."""
    reference = gym.make("CliffWalking-v1").unwrapped
    env = ns_pz.make_gym("ns_pz/CliffWalking-v0", max_episode_steps=10_000)
    reference.reset(seed=1)
    obs, _ = env.reset(seed=1)
    falls = 0
    for action in np.random.default_rng(2).integers(0, 4, 2000).tolist():
        state, reward, terminated, _, _ = reference.step(action)
        obs, obs_reward, obs_terminated, _, _ = env.step(action)
        assert (obs["state"], obs_reward, obs_terminated) == (state, reward, terminated)
        falls += reward == -100
        if terminated:
            reference.reset()
            env.reset()
    assert falls > 0


def test_cliff_walking_paper_reward_and_best_return():
    """With goal_reward=100 the shortest safe path (13 moves) returns 100 - 12 = 88."""
    env = ns_pz.make_gym("ns_pz/CliffWalking-v0", goal_reward=100.0)
    env.reset(seed=0)
    total = 0.0
    for action in [0] + [1] * 11 + [2]:  # UP, RIGHT x 11, DOWN
        _, reward, terminated, _, _ = env.step(action)
        total += reward
    assert terminated and total == 88.0
    with pytest.raises(ValueError, match="goal_reward=nan must be finite"):
        CliffWalkingFamily(goal_reward=math.nan)


def test_cliff_walking_slip_outcomes():
    """Outcomes are [intended, action+1, action-1, reverse]: UP reversed is DOWN, into the cliff."""
    family = CliffWalkingFamily()
    start = 36
    up = family._table[start][0]
    assert [o[0] for o in up] == [24, start, start, start]
    assert up[1] == (start, -100.0, False)  # UP turned by +1 is RIGHT: the cliff, back to start
    assert up[3] == (start, -1.0, False)  # reversed: DOWN off the grid, stays at the start
    env = ns_pz.make_gym("ns_pz/CliffWalking-v0", params={"slip": (0.0, 0.0, 0.0, 1.0)})
    env.reset(seed=0)
    env.step(0)  # reversed UP: stays
    obs, reward, *_ = env.step(3)  # reversed LEFT is RIGHT: into the cliff
    assert obs["state"] == start and reward == -100.0


def test_bridge_map_facts():
    """Start (2, 4); goals (2, 0) and (2, 7) pay +1; 22 holes pay -1; the bridge is 3 moves."""
    family = BridgeFamily()
    assert family.start_states == (20,)
    holes = [s for s in range(40) if family.cell(s) == "H"]
    assert len(holes) == 22
    table = family.outcomes(family.default_params())
    assert table.rewards[22, 2, 0] == 1.0 and table.terminals[22, 2, 0]  # (2, 6) RIGHT -> goal
    assert table.rewards[17, 0, 0] == 1.0  # (2, 1) LEFT -> the left goal
    assert table.rewards[21, 3, 0] == -1.0 and table.terminals[21, 3, 0]  # off the bridge
    env = ns_pz.make_gym("ns_pz/Bridge-v0")
    env.reset(seed=0)
    rewards = [env.step(2)[1] for _ in range(3)]
    assert rewards == [0.0, 0.0, 1.0]


def test_bridge_variant_map_cuts_the_safe_road():
    """NS-Gym's later map has a hole at (2, 2); unknown maps are refused."""
    assert BridgeFamily("extra_hole").cell(18) == "H" and BridgeFamily().cell(18) == "F"
    with pytest.raises(ValueError, match=r"map_name='new' is not a map; allowed: \['extra_hole'"):
        BridgeFamily("new")


def test_split_bridge_uses_the_slip_of_the_half_the_agent_is_in():
    """slip_left acts on columns 0-3 only, slip_right on columns 4-7 only."""
    family = SplitBridgeFamily()
    assert family.slip_param_of(20) == "slip_right" and family.slip_param_of(19) == "slip_left"
    env = ns_pz.make_gym("ns_pz/BridgeSplit-v0", params={"slip_left": (0.0, 1.0, 0.0)})
    env.reset(seed=0)
    assert env.step(0)[0]["state"] == 19  # from (2, 4), right half: LEFT as intended
    assert env.step(0)[0]["state"] == 27  # from (2, 3), left half: LEFT turned +1 is DOWN


def test_bridge_honours_the_seed():
    """Slippery Bridge episodes are reproducible from the seed and differ between seeds."""

    def episode(seed: int) -> list:
        env = ns_pz.make_gym("ns_pz/Bridge-v0", params={"slip": (0.4, 0.3, 0.3)})
        env.reset(seed=seed)
        states, done = [], False
        while not done:
            obs, _, terminated, truncated, _ = env.step(0)
            states.append(obs["state"])
            done = terminated or truncated
        return states

    assert episode(3) == episode(3)
    assert len({tuple(episode(seed)) for seed in range(10)}) > 1


def test_frozen_lake_repr_tells_reward_schedules_apart():
    """Caches and detectors key on the family's repr: another reward schedule, another key."""
    from ns_pz.envs.frozen_lake import FrozenLakeFamily

    default, harsh = FrozenLakeFamily(), FrozenLakeFamily(reward_schedule=(1.0, -1.0, 0.0))
    assert repr(default) != repr(harsh) and "reward_schedule" not in repr(default)
    assert "reward_schedule=(1.0, -1.0, 0.0)" in repr(harsh)
