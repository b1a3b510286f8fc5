"""Double DQN: the target, the training on θ_0, the agent and its catalog entry."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import evaluate
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.config import DDQNArgs

import ns_pz

torch = pytest.importorskip("torch")
from ns_pz.agents.learning.ddqn import double_dqn_target, dqn_target, train_ddqn  # noqa: E402
from ns_pz.agents.learning.trained import training_env  # noqa: E402

FROZEN_LAKE = {"slip": [0.7, 0.15, 0.15]}


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))


def test_double_target_differs_from_vanilla_exactly_where_the_argmaxes_differ():
    """Online net picks, target net evaluates; vanilla takes the target net's max."""
    online = torch.tensor([[1.0, 5.0, 2.0], [4.0, 0.0, 1.0], [0.0, 3.0, 9.0], [2.0, 1.0, 0.0]])
    target = torch.tensor([[7.0, 1.0, 3.0], [6.0, 2.0, 8.0], [1.0, 2.0, 5.0], [3.0, 4.0, 1.0]])
    rewards = torch.tensor([1.0, 0.0, -1.0, 0.5])
    terminated = torch.tensor([0.0, 0.0, 0.0, 1.0])
    gamma = 0.9
    double = double_dqn_target(online, target, rewards, terminated, gamma)
    vanilla = dqn_target(target, rewards, terminated, gamma)
    # row 0: online argmax 1 -> target 1.0; vanilla max 7.0
    # row 1: online argmax 0 -> target 6.0; vanilla max 8.0
    # row 2: online argmax 2 -> target 5.0 = the target's own max: equal
    # row 3: terminal, no bootstrap: equal
    torch.testing.assert_close(double, torch.tensor([1.9, 5.4, 3.5, 0.5]))
    torch.testing.assert_close(vanilla, torch.tensor([7.3, 7.2, 3.5, 0.5]))
    assert (double != vanilla).tolist() == [True, True, False, False]


def test_training_is_reproducible_from_its_seed():
    """Training is reproducible from its seed."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    args = DDQNArgs(total_steps=1500, learning_starts=100).for_family(env.family)
    first, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    second, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    other, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 4)
    assert all(np.array_equal(first[k], second[k]) for k in first)
    assert not all(np.array_equal(first[k], other[k]) for k in first)
    assert [first[f"q.{i}.weight"].shape for i in range(2)] == [(64, 16), (4, 64)]


def _mean_return(env_id, params, agent, seeds, **kwargs):
    episodes = evaluate(lambda: ns_pz.make_gym(env_id, params=params, **kwargs), agent, seeds)
    return float(np.mean([e.episode_return for e in episodes]))


def test_ddqn_learns_frozen_lake_at_theta0():
    """20k steps (seconds) give a greedy policy far above random on θ_0 (p = 0.7)."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    agent = agent_entry("ddqn").make(env, {"total_steps": 20_000})
    learned = _mean_return("ns_pz/FrozenLake-v0", FROZEN_LAKE, agent, range(100))
    random = _mean_return(
        "ns_pz/FrozenLake-v0", FROZEN_LAKE, RandomAgent(env.action_space), range(100)
    )
    assert random < 0.1 and learned > 0.5


def test_ddqn_learns_cartpole_at_theta0():
    """Ddqn learns cartpole at theta0."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0", max_episode_steps=300)
    agent = agent_entry("ddqn").make(env, {"total_steps": 20_000})
    learned = _mean_return("ns_pz/CartPole-v0", {}, agent, range(10), max_episode_steps=300)
    random = _mean_return(
        "ns_pz/CartPole-v0", {}, RandomAgent(env.action_space), range(10), max_episode_steps=300
    )
    assert random < 40 and learned > 3 * random


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("total_steps", 0, "total_steps=0 must be >= 1"),
        ("gamma", 1.5, r"gamma=1.5 must lie in \[0.0, 1.0\]"),
        ("hidden", [64, 0], "hidden=0 must be >= 1"),
        ("hidden", "64", "must be a non-empty list"),
        ("seed", 1.0, "seed=1.0 must be an integer"),
    ],
)
def test_bad_args_are_refused(field, value, match):
    """Bad args are refused."""
    with pytest.raises((TypeError, ValueError), match=match):
        DDQNArgs(**{field: value})
