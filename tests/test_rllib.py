"""The game under RLlib: the flat, RLlib-ready AEC wrapper, and PPO training both seats.

The wrapper tests need no Ray. The training test needs the ``rllib`` extra (``ray[rllib]``, which
pins Gymnasium 1.2.x, so it lives in a venv of its own) and is skipped cleanly without it.
"""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import api_test

import ns_pz
from ns_pz import DECISION, MONITOR, NATURE
from ns_pz.nature import NatureConstraints
from ns_pz.rllib import GameForRLlib

LAKE = {
    "params": {"slip": (1.0, 0.0, 0.0)},
    "constraints": NatureConstraints(lipschitz=0.1, budget=0.6),
    "notification": "detailed",
    "max_episode_steps": 20,
}


def lake_game(**kwargs):
    """A FrozenLake game with a learnable nature (and flag-only monitor actions)."""
    return ns_pz.make(
        "ns_pz/FrozenLake-v0", nature_action="normalized", monitor_action="flags", **LAKE, **kwargs
    )


def test_scripted_monitor_hides_the_monitor_and_flattens_observations():
    """Two learners with flat float32 Box observations; the oracle monitor plays in between."""
    env = GameForRLlib(lake_game())
    assert env.possible_agents == [NATURE, DECISION]
    env.reset(seed=3)
    seen = []
    for agent in env.agent_iter():
        observation, _, terminated, truncated, _ = env.last()
        space = env.observation_space(agent)
        assert isinstance(space, spaces.Box) and space.dtype == np.float32
        assert observation.dtype == np.float32 and space.contains(observation)
        seen.append(agent)
        if terminated or truncated:
            env.step(None)
        else:
            env.step(np.zeros(3, np.float32) if agent == NATURE else 2)  # right, along row 0
    assert MONITOR not in seen and seen[:4] == [NATURE, DECISION, NATURE, DECISION]
    # The game itself ran every turn, the monitor's included, up to the time limit.
    assert env.game.process.t == 20 and len(seen) == 2 * 20 + 2


# PettingZoo's api_test resets with options={"options": 1} to see that an unknown option does
# not crash; ns_pz warns that it ignores it, as it should for a user's typo. Expected here.
@pytest.mark.filterwarnings("ignore:reset options \\['options'\\] are not understood:UserWarning")
@pytest.mark.parametrize("scripted_monitor", [True, False])
def test_wrapper_passes_pettingzoos_api_test(scripted_monitor):
    """PettingZoo's own API test accepts the wrapper, with the monitor hidden or learning."""
    api_test(GameForRLlib(lake_game(), scripted_monitor=scripted_monitor), num_cycles=30)


def test_the_agents_one_hot_state_is_in_the_flat_observation():
    """Flattening keeps the information: the agent's cell is the one-hot block of ``state``."""
    env = GameForRLlib(lake_game())
    env.reset(seed=0)
    env.step(np.zeros(3, np.float32))  # nature: no change
    flat = env.observe(DECISION)
    game_observation = env.game.observe(DECISION)
    unflat = spaces.unflatten(env.game.observation_space(DECISION), flat.astype(np.float64))
    assert int(unflat["state"]) == int(game_observation["state"]) == 0


def test_refused_spaces_are_named():
    """A Δθ nature or a Dict monitor action is refused up front, naming the option to set."""
    with pytest.raises(ValueError, match="nature_action='delta'"):
        GameForRLlib(ns_pz.make("ns_pz/FrozenLake-v0"))
    dict_monitor = ns_pz.make("ns_pz/FrozenLake-v0", nature_action="normalized")
    with pytest.raises(ValueError, match="monitor_action='flags'"):
        GameForRLlib(dict_monitor, scripted_monitor=False)
    GameForRLlib(dict_monitor)  # fine while the monitor is scripted


def _rllib():
    """RLlib's PPO, or skip (ray[rllib] is not installed, or not importable here)."""
    try:
        from ray.rllib.algorithms import ppo
    except Exception as error:  # ray without its rllib extra fails with ModuleNotFoundError
        pytest.skip(f"ray[rllib] is not importable: {error!r}")
    return ppo


def _weights(algo, seat):
    state = algo.get_module(seat).get_state()
    return {name: np.array(value, copy=True) for name, value in state.items()}


@pytest.mark.parametrize("flatten", [True, False])
def test_ppo_trains_nature_and_agent_under_rllib(flatten):
    """Two PPO iterations in PettingZooEnv update both seats' policies; no space is refused."""
    _rllib()
    import ray

    from ns_pz.rllib import ppo_config

    config = ppo_config(
        "ns_pz/FrozenLake-v0",
        flatten=flatten,
        train_batch_size=160,
        minibatch_size=40,
        num_epochs=2,
        **LAKE,
    )
    algo = config.build_algo()
    try:
        before = {seat: _weights(algo, seat) for seat in (NATURE, DECISION)}
        for _ in range(2):
            result = algo.train()
        assert result["num_env_steps_sampled_lifetime"] >= 320
        for seat in (NATURE, DECISION):
            after = _weights(algo, seat)
            assert after.keys() == before[seat].keys()
            assert any(not np.array_equal(after[k], before[seat][k]) for k in after), seat
            assert seat in result["learners"]
        module = algo.get_module(NATURE)
        assert module.action_space == spaces.Box(-1.0, 1.0, (3,), np.float32)
    finally:
        algo.stop()
        ray.shutdown()
