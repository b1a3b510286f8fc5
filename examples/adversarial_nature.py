"""The AEC game with an adversarial nature: random Δθ actions, kept in check by the game.

Nature may move the slip vector by at most 0.1 (total variation) per step and 0.5 in all; the
game projects whatever it asks for onto that set. Swap the random nature action for a learned
policy's output to train an adversary.
"""

import numpy as np
from ns_pz.agents import SnapshotValueIteration

import ns_pz
from ns_pz.nature import NatureConstraints

game = ns_pz.make(
    "ns_pz/FrozenLake-v0",
    params={"slip": (1.0, 0.0, 0.0)},
    notification="detailed",
    constraints=NatureConstraints(lipschitz=0.1, budget=0.5),
    max_episode_steps=100,
)
agent = SnapshotValueIteration(gamma=0.99)
rng = np.random.default_rng(0)
game.reset(seed=0)
game.action_space(ns_pz.NATURE).seed(0)  # the naive adversary samples from nature's action space
agent.reset(rng)
returns = {name: 0.0 for name in game.possible_agents}
for name in game.agent_iter():
    observation, reward, terminated, truncated, _ = game.last()
    returns[name] += reward
    if terminated or truncated:
        game.step(None)
    elif name == ns_pz.NATURE:
        game.step(game.action_space(name).sample())  # a (very naive) adversary
    elif name == ns_pz.MONITOR:
        game.step(game.policy_action(name))  # the oracle monitor
    else:
        game.step(agent.act(observation, game.planning_model()))

truth = game.ground_truth()
print(f"returns: {returns}")
print(
    f"θ changed {len(truth.change_times)} times, total change {truth.total_change:.3f} (budget 0.5)"
)
print(f"final slip vector: {tuple(round(p, 3) for p in truth.theta.slip)}")
