"""PA-MCTS: the mix at the root, and its two limits (α = 0: MCTS; α = 1: the stale DDQN)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from ns_pz.agents.learning.pamcts import PAMCTS, mix, pamcts
from ns_pz.agents.learning.q_agent import DDQNAgent, QNetwork
from ns_pz.agents.search.mcts import uct

import ns_pz

FROZEN_LAKE = {"slip": [0.7, 0.15, 0.15]}


def _random_q_network(space, seed):
    """A fixed random Q-network (no training needed to test the mixing)."""
    rng = np.random.default_rng(seed)
    n = int(space.n)
    weights = {
        "q.0.weight": rng.normal(size=(8, n)),
        "q.0.bias": rng.normal(size=8),
        "q.1.weight": rng.normal(size=(4, 8)),
        "q.1.bias": rng.normal(size=4),
    }
    return QNetwork(weights, space)


def _states(seed):
    """A few (env, model) pairs along a random FrozenLake trajectory, with its planning models."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE, notification="detailed")
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(4):
        yield env
        _, _, terminated, truncated, _ = env.step(int(rng.integers(4)))
        if terminated or truncated:
            env.reset()


@pytest.mark.parametrize("normalise", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_alpha_zero_is_mcts(seed, normalise):
    """At α = 0, same generators, PA-MCTS plays exactly UCT's action."""
    for env in _states(seed):
        q = _random_q_network(env.family.observation_space, seed)
        common = dict(iterations=40, depth=20, c=math.sqrt(2), gamma=0.99)
        model = env.planning_model()
        twin = copy.deepcopy(model)  # the same transition generator state for both searches
        expected = uct(model, model.get_state(), np.random.default_rng(seed), **common)
        model = twin
        got = pamcts(
            model,
            model.get_state(),
            np.random.default_rng(seed),
            q_fn=lambda s, q=q: q(s),
            alpha=0.0,
            normalise=normalise,
            **common,
        )
        assert got.action == expected.action
        np.testing.assert_array_equal(got.visits, expected.visits)


@pytest.mark.parametrize("seed", range(3))
def test_alpha_one_is_the_stale_ddqn(seed):
    """At α = 1, PA-MCTS plays the greedy action of the stale Q-network, whatever the search."""
    for env in _states(seed):
        q = _random_q_network(env.family.observation_space, seed)
        agent = PAMCTS(q, alpha=1.0, iterations=30, depth=10)
        agent.reset(np.random.default_rng(seed))
        observation = {"state": env.process.state}
        assert agent.act(observation, env.planning_model()) == DDQNAgent(q).act(observation)


def test_mix_weights_normalised_values():
    """α q + (1 - α) G after min-max scaling; untried actions are never played for α < 1."""
    g = np.array([0.0, 10.0, 5.0, np.nan])
    q = np.array([3.0, 1.0, 2.0, 9.0])
    scores = mix(g, q, 0.25, normalise=True)
    q01 = (q - 1.0) / (8.0 + 1e-8)
    g01 = np.array([0.0, 10.0, 5.0]) / (10.0 + 1e-8)
    np.testing.assert_allclose(scores[:3], 0.25 * q01[:3] + 0.75 * g01)
    assert scores[3] == -np.inf
    assert int(np.argmax(mix(g, q, 1.0, normalise=True))) == 3
    flat = mix(np.array([1.0, 1.0, 1.0, 1.0]), q, 0.5, normalise=True)  # the paper-era NaN case
    assert np.isfinite(flat).all() and int(np.argmax(flat)) == 3  # the Q decides, no NaN


@pytest.mark.parametrize(
    ("alpha", "match"),
    [(1.5, r"alpha=1.5 must lie in \[0, 1\]"), ("x", "alpha='x' must be a real number")],
)
def test_bad_alpha_is_refused(alpha, match):
    """Bad alpha is refused."""
    q = _random_q_network(ns_pz.make_gym("ns_pz/FrozenLake-v0").family.observation_space, 0)
    with pytest.raises((TypeError, ValueError), match=match):
        PAMCTS(q, alpha=alpha)
