"""A Gymnasium CartPole whose pole gets heavier every step, with detailed notification."""

import gymnasium as gym

import ns_pz  # noqa: F401 - registers the ns_pz/... environments
from ns_pz.nature import ContinuousScheduler, IncrementUpdate, ScriptedNature

nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=1), k=0.1)})
env = gym.make("ns_pz/CartPole-v0", nature=nature, notification="detailed")

obs, info = env.reset(seed=0)
total, done, first_notice = 0.0, False, None
while not done:
    action = 1 if obs["state"][2] + 0.5 * obs["state"][3] > 0 else 0  # push toward the lean
    obs, reward, terminated, truncated, info = env.step(action)
    total += reward
    done = terminated or truncated
    if first_notice is None and obs["env_change"].any():
        first_notice = obs

truth = env.unwrapped.ground_truth()
print(f"return {total:.0f}; masspole went {truth.theta0.masspole} -> {truth.theta.masspole:.1f} kg")
print(
    f"first notification, after step {first_notice['relative_time'][0]:.0f}: "
    f"env_change={first_notice['env_change']}, delta_change={first_notice['delta_change']}"
)
