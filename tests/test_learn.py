"""ns_pz.learn: learning happens (small seeded runs), RARL logs and checkpoints, seeding.

Skipped without the ``learn`` extra (stable-baselines3).
"""

from __future__ import annotations

import json
import statistics

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO  # noqa: E402

import ns_pz  # noqa: E402
from ns_pz import DECISION, NATURE  # noqa: E402
from ns_pz.learn import TrainArgs, episode_returns, make_model, rarl, train_adversary  # noqa: E402
from ns_pz.nature import (  # noqa: E402
    ContinuousScheduler,
    IncrementUpdate,
    NatureConstraints,
    OscillatingUpdate,
    PolicyNature,
    RandomNature,
    RandomWalk,
    ScriptedNature,
)

CARTPOLE = "ns_pz/CartPole-v0"
# Nature may only shorten or lengthen the pole, 2 cm a step and 45 cm an episode.
POLE = {
    "constraints": NatureConstraints(
        lipschitz={"length": 0.02},
        budget={
            "length": 0.45,
            "gravity": 0,
            "masscart": 0,
            "masspole": 0,
            "force_mag": 0,
            "tau": 0,
        },
    ),
    "max_episode_steps": 200,
}
PPO_SMALL = {"n_steps": 256, "batch_size": 64, "learning_rate": 3e-3}


def balance(obs):
    """A fixed controller that balances the stationary pole for the whole episode."""
    state = obs["state"]
    return int(0.1 * state[0] + 0.3 * state[1] + state[2] + 0.5 * state[3] > 0)


def agents_return(nature, episodes=range(50, 60)):
    """The controller's mean return against ``nature`` (``None``: θ fixed)."""
    policies = {} if nature is None else {NATURE: nature}
    env = ns_pz.single_agent(CARTPOLE, DECISION, policies, **POLE)
    return statistics.fmean(episode_returns(env, balance, episodes))


def test_a_ppo_adversary_learns_to_beat_the_scripted_baselines():
    """After 3,000 steps the PPO nature costs the controller more than scripted or random ones."""
    model = train_adversary(
        CARTPOLE,
        balance,
        args=TrainArgs(total_timesteps=3072, hyperparameters=PPO_SMALL),
        seed=0,
        nature_observes_state=True,
        **POLE,
    )
    learned = agents_return(PolicyNature(model, observes_state=True))
    seat = ns_pz.single_agent(
        CARTPOLE, NATURE, {DECISION: balance}, nature_observes_state=True, **POLE
    )
    untrained = agents_return(
        PolicyNature(make_model(seat, TrainArgs(hyperparameters=PPO_SMALL), 0), observes_state=True)
    )
    every_step = ContinuousScheduler(start=1)
    baselines = {
        "static": agents_return(None),
        "random": agents_return(RandomNature(scale=0.05)),
        "random walk": agents_return(
            ScriptedNature({"length": RandomWalk(every_step, sigma=0.02)})
        ),
        "oscillating": agents_return(
            ScriptedNature({"length": OscillatingUpdate(every_step, delta=0.02)})
        ),
        "longer": agents_return(ScriptedNature({"length": IncrementUpdate(every_step, k=0.02)})),
        "untrained PPO": untrained,
    }
    assert baselines["static"] == 200.0
    for name, value in baselines.items():
        assert learned < value, (name, learned, baselines)


def test_rarl_logs_every_round_and_its_checkpoints_load_and_act_identically(tmp_path):
    """One log line and one pair of checkpoints per round; a loaded agent acts as the live one."""
    small = TrainArgs(total_timesteps=128, hyperparameters={"n_steps": 128, "batch_size": 64})
    result = rarl(
        CARTPOLE,
        rounds=2,
        agent_args=small,
        nature_args=small,
        seed=3,
        out_dir=tmp_path,
        eval_episodes=2,
        **POLE,
    )
    lines = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    assert [line["round"] for line in lines] == [1, 2] == [entry.round for entry in result.log]
    assert [line["agent_timesteps"] for line in lines] == [128, 256]
    assert [line["nature_timesteps"] for line in lines] == [128, 256]
    env = ns_pz.single_agent(CARTPOLE, DECISION, **POLE)
    nature_env = ns_pz.single_agent(CARTPOLE, NATURE, {DECISION: balance}, **POLE)
    agent = PPO.load(tmp_path / "round_2" / "agent.zip")
    nature = PPO.load(tmp_path / "round_2" / "nature.zip")
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        nature_obs, _ = nature_env.reset(seed=seed)
        assert (
            agent.predict(obs, deterministic=True)[0]
            == result.agent.predict(obs, deterministic=True)[0]
        )
        np.testing.assert_array_equal(
            nature.predict(nature_obs, deterministic=True)[0],
            result.nature.predict(nature_obs, deterministic=True)[0],
        )
    round_1 = PPO.load(tmp_path / "round_1" / "agent.zip")
    assert round_1.num_timesteps == 128


def test_training_is_reproducible_from_its_seed():
    """Two adversaries trained with the same seed have the same weights; another seed differs."""

    def weights(seed):
        model = train_adversary(
            CARTPOLE,
            balance,
            args=TrainArgs(total_timesteps=128, hyperparameters={"n_steps": 128, "batch_size": 64}),
            seed=seed,
            **POLE,
        )
        return [p.detach().numpy().copy() for p in model.policy.parameters()]

    first, again, other = weights(5), weights(5), weights(6)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(np.array_equal(a, b) for a, b in zip(first, other, strict=True))


def test_bad_training_arguments_are_named():
    """TrainArgs and rarl refuse bad values, naming them."""
    with pytest.raises(ValueError, match="algo='Nope'"):
        TrainArgs(algo="Nope")
    with pytest.raises(ValueError, match="total_timesteps=0"):
        TrainArgs(total_timesteps=0)
    with pytest.raises(ValueError, match="rounds=0"):
        rarl(CARTPOLE, rounds=0)
