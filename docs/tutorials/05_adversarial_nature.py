"""Training an adversarial nature
==============================

Every seat of the game can be the learner of an ordinary Gymnasium environment with the other
seats fixed (:func:`ns_pz.single_agent`). Here nature learns, with Stable-Baselines3's PPO,
to hurt a fixed planner on FrozenLake, inside constraints the game enforces: the slip vector
may move by at most 0.1 (total variation) per step and 0.6 in all. The budget is tiny so the
page builds in seconds; train for longer to get a real adversary.
"""

# %%
# Nature's seat as a Gymnasium environment
# ----------------------------------------

import matplotlib.pyplot as plt
import numpy as np
from ns_pz.agents import SnapshotValueIteration

import ns_pz
from ns_pz.learn import TrainArgs, episode_returns, mean_and_se, train
from ns_pz.nature import NatureConstraints, PolicyNature

constraints = NatureConstraints(lipschitz=0.1, budget=0.6)
setting = dict(
    params={"slip": (1.0, 0.0, 0.0)},
    constraints=constraints,
    notification="detailed",
    max_episode_steps=30,
)
adversary_env = ns_pz.single_agent(
    "ns_pz/FrozenLake-v0",
    learner="nature",
    policies={"agent": SnapshotValueIteration(gamma=0.99)},
    nature_reward="zero_sum",
    **setting,
)
print("nature observes", adversary_env.observation_space)
print("nature acts in", adversary_env.action_space)

# %%
# Train
# -----
#
# ``ns_pz.learn.train`` is a thin wrapper over SB3 (``train_adversary`` does both steps in one
# call). Nature's action is ``Box(-1, 1)`` per element of θ, scaled to its per-step allowance
# and projected onto the constraints, so even an untrained network produces only valid θ.

model = train(adversary_env, TrainArgs("PPO", 1024, {"n_steps": 256, "batch_size": 64}), seed=0)

# %%
# Evaluate
# --------
#
# Nature's return is minus the agent's. A nature that never moves is the baseline.

seeds = range(20)
learned = mean_and_se(episode_returns(adversary_env, model, seeds))
no_change = np.zeros(adversary_env.action_space.shape, np.float32)  # zero means "no change"
idle = mean_and_se(episode_returns(adversary_env, lambda obs: no_change, seeds))
print(f"nature's return: learned {learned[0]:.2f} ± {learned[1]:.2f}")
print(f"nature's return: idle {idle[0]:.2f} ± {idle[1]:.2f}")

# %%
# Put the trained policy back into the ordinary view as a nature, and look at the slip
# trajectory it chose in one episode.

env = ns_pz.make_gym(
    "ns_pz/FrozenLake-v0", nature=PolicyNature(model), ground_truth_info=True, **setting
)
agent = SnapshotValueIteration(gamma=0.99)
obs, info = env.reset(seed=0)
agent.reset(np.random.default_rng(0))
intended, done = [info["theta"]["slip"][0]], False
while not done:
    obs, reward, terminated, truncated, info = env.step(agent.act(obs, env.planning_model()))
    intended.append(info["theta"]["slip"][0])
    done = terminated or truncated
print(f"total change {env.ground_truth().total_change:.2f} (budget 0.6)")

fig, ax = plt.subplots(figsize=(5, 3))
ax.step(range(len(intended)), intended, where="post")
ax.set_ylim(0, 1.05)
ax.set_xlabel("transition t")
ax.set_ylabel("P(intended move)")
ax.set_title("θ chosen by the learned nature")
fig.tight_layout()
