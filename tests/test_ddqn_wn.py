"""DDQN-WN: fine-tuning in the handed model on notified changes, with a fixed step budget."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.q_agent import DDQNAgent, ddqn_q_network

import ns_pz
from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

pytest.importorskip("torch")

SMALL = {"total_steps": 1500, "learning_starts": 100}


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))


def _env():
    nature = ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [[0.4, 0.3, 0.3]])}
    )
    return ns_pz.make_gym(
        "ns_pz/FrozenLake-v0",
        params={"slip": [1.0, 0.0, 0.0]},
        nature=nature,
        notification="detailed",
        max_episode_steps=30,
    )


def _agent(env, **hyper):
    agent = agent_entry("ddqn_wn").make(env, {"ddqn": SMALL, **hyper})
    agent.reset(np.random.default_rng(0))
    return agent


def test_without_a_notification_it_is_the_greedy_ddqn():
    """No change flagged: no fine-tuning, the θ_0 network's greedy action."""
    env = _env()
    observation, _ = env.reset(seed=0)
    agent = _agent(env)
    greedy = DDQNAgent(ddqn_q_network(env, DDQNArgs(**SMALL)))
    assert agent.act(observation, env.planning_model()) == greedy.act(observation)
    assert agent.fine_tunings == 0


def test_a_notified_change_fine_tunes_within_its_budget():
    """After the change the agent simulates exactly model_steps transitions and updates."""
    env = _env()
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(1)  # the change fires at transition 1 ...
    observation, *_ = env.step(1)  # ... and is notified in the observation after it
    assert observation["env_change"].any()
    agent = _agent(env, model_steps=120, gradient_steps=10)
    before = [p.detach().clone() for p in agent.online.parameters()]
    model = env.planning_model()
    state = model.get_state()
    agent.act(observation, model)
    assert agent.fine_tunings == 1 and agent.buffer.size == 120
    assert model.get_state() == state  # the handed model is left where it was
    after = list(agent.online.parameters())
    assert any(
        not np.array_equal(b.numpy(), a.detach().numpy())
        for b, a in zip(before, after, strict=True)
    )


def test_fine_tuning_is_reproducible_from_the_agent_generator():
    """Same agent seed, same model: the same fine-tuned network."""
    results = []
    for _ in range(2):
        env = _env()
        env.reset(seed=0)
        env.step(1)
        observation, *_ = env.step(1)
        agent = _agent(env, model_steps=80, gradient_steps=5)
        agent.act(observation, env.planning_model())
        results.append([p.detach().numpy().copy() for p in agent.online.parameters()])
    assert all(np.array_equal(a, b) for a, b in zip(*results, strict=True))


def test_bad_budget_is_refused():
    """A negative budget names the parameter."""
    with pytest.raises(ValueError, match="model_steps=-1 must be an int >= 0"):
        agent_entry("ddqn_wn").artefacts(_env(), {"model_steps": -1})


def test_acting_leaves_torchs_thread_count_as_it_was():
    """Fine-tuning runs on one thread, and gives the caller's thread count back."""
    import torch

    env = _env()
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(1)
    observation, *_ = env.step(1)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        agent = _agent(env, model_steps=20, gradient_steps=2)
        agent.act(observation, env.planning_model())
        assert agent.fine_tunings == 1 and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)
