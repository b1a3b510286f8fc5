"""Train a nature adversary with PPO against a fixed planner, and compare it with a schedule.

The decision agent is value iteration on a snapshot of FrozenLake with θ_0 (never told of
changes: notification ``none``). Nature may move the slip vector by 0.1 a step and 0.6 an
episode (the game enforces this whatever the network asks), and it sees the agent's cell.
Needs the ``learn`` extra. ``--steps 20000`` trains longer (the default takes seconds).
"""

import argparse
import statistics

import gymnasium as gym
import numpy as np
from ns_pz.agents import SnapshotValueIteration

import ns_pz  # noqa: F401 - registers the ns_pz/... environments
from ns_pz.learn import TrainArgs, train_adversary
from ns_pz.nature import (
    ContinuousScheduler,
    NatureConstraints,
    PolicyNature,
    ScriptedNature,
    TargetReversion,
)

parser = argparse.ArgumentParser()
parser.add_argument("--steps", type=int, default=1024, help="nature's PPO steps")
steps = parser.parse_args().steps

setup = {
    "params": {"slip": (1.0, 0.0, 0.0)},
    "constraints": NatureConstraints(lipschitz=0.1, budget=0.6),
    "notification": "none",
    "max_episode_steps": 100,
}
agent = SnapshotValueIteration(gamma=0.99)
model = train_adversary(
    "ns_pz/FrozenLake-v0",
    agent,
    args=TrainArgs(total_timesteps=steps, hyperparameters={"n_steps": 256, "batch_size": 64}),
    seed=0,
    nature_observes_state=True,
    **setup,
)


def agents_mean_return(nature, episodes=30):
    """The planner's mean return in the Gymnasium view against ``nature``."""
    env = gym.make("ns_pz/FrozenLake-v0", nature=nature, **setup)
    returns = []
    for seed in range(episodes):
        obs, _ = env.reset(seed=seed)
        agent.reset(np.random.default_rng(seed))
        total, done = 0.0, False
        while not done:
            action = agent.act(obs, env.unwrapped.planning_model())
            obs, reward, terminated, truncated, _ = env.step(action)
            total, done = total + reward, terminated or truncated
        returns.append(total)
    return statistics.fmean(returns)


push = ScriptedNature({"slip": TargetReversion(ContinuousScheduler(start=1), (0, 1, 0), 0.5)})
print(f"nature trained for {model.num_timesteps} steps")
print(f"agent's return, θ fixed:              {agents_mean_return(None):.2f}")
print(f"agent's return, scripted push:        {agents_mean_return(push):.2f}")
adversary = PolicyNature(model, observes_state=True)
print(f"agent's return, PPO adversary:        {agents_mean_return(adversary):.2f}")
