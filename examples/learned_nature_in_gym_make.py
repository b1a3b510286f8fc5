"""A trained nature, saved and loaded, dropped into ``gym.make(..., nature=PolicyNature(model))``.

Any SB3 model trained in nature's seat (``ns_pz.single_agent(..., learner="nature")``) drives the
Gymnasium view, the AEC game and the vector env through the same observation and action
conventions it was trained with. Needs the ``learn`` extra; ``--steps 20000`` trains longer.
"""

import argparse
import tempfile
from pathlib import Path

import gymnasium as gym
from stable_baselines3 import PPO

import ns_pz
from ns_pz.nature import NatureConstraints, PolicyNature

parser = argparse.ArgumentParser()
parser.add_argument("--steps", type=int, default=512, help="nature's PPO steps")
steps = parser.parse_args().steps


def balance(obs):
    """A fixed CartPole controller: push towards the pole's lean."""
    state = obs["state"]
    return int(0.1 * state[0] + 0.3 * state[1] + state[2] + 0.5 * state[3] > 0)


setup = {"constraints": NatureConstraints(lipschitz={"length": 0.02}, budget={"length": 0.4})}
seat = ns_pz.single_agent("ns_pz/CartPole-v0", "nature", {ns_pz.DECISION: balance}, **setup)
model = PPO("MlpPolicy", seat, n_steps=256, batch_size=64, seed=0, verbose=0).learn(steps)
path = Path(tempfile.mkdtemp()) / "nature.zip"
model.save(path)

nature = PolicyNature(PPO.load(path))  # the same conventions as in training
env = gym.make("ns_pz/CartPole-v0", nature=nature, **setup)
obs, _ = env.reset(seed=0)
total, done = 0.0, False
while not done:
    obs, reward, terminated, truncated, _ = env.step(balance(obs))
    total, done = total + reward, terminated or truncated
truth = env.unwrapped.ground_truth()
print(f"return {total:.0f} against the loaded nature ({len(truth.change_times)} changes)")
print(f"pole half-length went {truth.theta0.length} -> {truth.theta.length:.3f} m")
