"""Quickstart: the Gymnasium view and the game
===========================================

ns_pz gives every environment two faces: an ordinary Gymnasium environment (the *view*), in
which nature and the monitor are built in, and a PettingZoo AEC game of three seats. This page
builds a CartPole whose pole gets heavier every step, runs it through both faces, and plots the
parameter trajectory nature produced.
"""

# %%
# The view
# --------
#
# A nature is a policy over θ. The scripted kind combines a *scheduler* (when to change) and an
# *update function* (how): here the pole's mass grows by 0.1 kg at every step from step 1 on.
# ``notification="detailed"`` tells the agent which parameter changed and by how much.

import gymnasium as gym
import matplotlib.pyplot as plt

import ns_pz  # registers the ns_pz/... environments with Gymnasium
from ns_pz.nature import ContinuousScheduler, IncrementUpdate, ScriptedNature

nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=1), k=0.1)})
env = gym.make(
    "ns_pz/CartPole-v0",
    nature=nature,
    notification="detailed",
    ground_truth_info=True,  # info["theta"]: the θ each transition ran under (evaluation only)
)
obs, info = env.reset(seed=0)
print(env.observation_space)
print(obs)

# %%
# Play one episode with a hand-written controller that pushes toward the lean. The observation
# is a flat ``Dict``: the base state, one change flag and one change size per parameter, and
# the clock.

masses, notices = [info["theta"]["masspole"]], []
done, total = False, 0.0
while not done:
    action = 1 if obs["state"][2] + 0.5 * obs["state"][3] > 0 else 0
    obs, reward, terminated, truncated, info = env.step(action)
    total += reward
    done = terminated or truncated
    masses.append(info["theta"]["masspole"])
    notices.append(float(obs["delta_change"][2]))  # masspole is θ's third field
print(f"return {total:.0f} after {len(notices)} steps")
first = next(i for i, size in enumerate(notices) if size > 0)
print(f"first notification: {notices[first]:.2f} kg, at relative_time {first + 1}")

# %%
# The θ trajectory: the mass in force for each transition. Transition 0 ran under θ_0; the
# first change fired at step 1 (see :doc:`/model`).

fig, ax = plt.subplots(figsize=(6, 3))
ax.step(range(len(masses)), masses, where="post")
ax.set_xlabel("transition t")
ax.set_ylabel("masspole (kg) in force")
ax.set_title("θ trajectory of one episode")
fig.tight_layout()

# %%
# Search agents plan with a model, not a copy of the environment. At ``detailed`` it holds the
# latest θ the agent has been told of; ``ground_truth()`` is the evaluation-only truth.

model = env.unwrapped.planning_model()
truth = env.unwrapped.ground_truth()
print(f"planning model assumes masspole={model.theta.masspole:.1f}")
print(f"θ_0 masspole={truth.theta0.masspole}, changes recorded: {len(truth.change_times)}")

# %%
# The game
# --------
#
# The same environment as a PettingZoo AEC game. Seats take turns ``nature → monitor → agent``;
# ``policy_action`` asks the configured nature or monitor for its move, so you can replace any
# seat by your own policy.

game = ns_pz.make("ns_pz/FrozenLake-v0", notification="basic", max_episode_steps=20)
game.reset(seed=0)
game.action_space(ns_pz.DECISION).seed(0)
turns = []
for agent in game.agent_iter():
    obs, reward, terminated, truncated, info = game.last()
    if terminated or truncated:
        action = None
    elif agent == ns_pz.DECISION:
        action = game.action_space(agent).sample()
    else:
        action = game.policy_action(agent)
    turns.append(agent)
    game.step(action)
print(turns[:7], "...", f"{len(turns)} turns")
