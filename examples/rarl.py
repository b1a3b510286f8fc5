"""RARL on CartPole: agent and nature take turns learning against each other's frozen policy.

Nature may lower the push force, shorten the pole and coarsen the clock, each within a
per-step (Lipschitz) bound and a budget of its own, in its own unit. Every round writes both
models and a log line to ``--out``. Needs the ``learn`` extra; ``--steps 30000`` trains longer.
"""

import argparse
import json
import tempfile
from pathlib import Path

from stable_baselines3 import PPO

from ns_pz.learn import TrainArgs, rarl
from ns_pz.nature import NatureConstraints

parser = argparse.ArgumentParser()
parser.add_argument("--steps", type=int, default=256, help="steps per side and round")
parser.add_argument("--rounds", type=int, default=2)
parser.add_argument("--out", default=None, help="checkpoint folder (default: a temporary one)")
options = parser.parse_args()
out = Path(options.out or tempfile.mkdtemp(prefix="rarl-"))

constraints = NatureConstraints(
    lipschitz={"force_mag": 0.5, "length": 0.02, "tau": 0.002},
    budget={
        "force_mag": 8.0,
        "length": 0.35,
        "tau": 0.04,
        "gravity": 0,
        "masscart": 0,
        "masspole": 0,
    },  # a budget of 0 freezes a parameter
)
ppo = {"n_steps": 128, "batch_size": 64}
result = rarl(
    "ns_pz/CartPole-v0",
    rounds=options.rounds,
    agent_args=TrainArgs(total_timesteps=options.steps, hyperparameters=ppo),
    nature_args=TrainArgs(total_timesteps=options.steps, hyperparameters=ppo),
    seed=0,
    out_dir=out,
    eval_episodes=2,
    nature_observes_state=True,
    constraints=constraints,
)
for line in (out / "log.jsonl").read_text().splitlines():
    entry = json.loads(line)
    print(
        f"round {entry['round']}: agent {entry['agent_timesteps']} steps, nature "
        f"{entry['nature_timesteps']} steps; agent's return vs nature "
        f"{entry['agent_return_mean']:.1f} ± {entry['agent_return_se']:.1f}"
    )
agent = PPO.load(out / f"round_{options.rounds}" / "agent.zip")
print(f"checkpoints in {out}; the last agent loads back as {type(agent).__name__}")
