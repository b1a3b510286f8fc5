"""HalfCheetah whose torso gets heavier every step: does an SB3 learner do better when told?

Needs the ``mujoco`` and ``learn`` extras. The torso mass drifts up by ``DRIFT`` kg per step
from the first decision epoch on; one learner sees nothing about it (``notification="none"``),
the other sees the change flags and sizes (``"detailed"``: the observation's ``delta_change``
holds how much the mass moved). Both train for the same number of steps with the same seed and
are scored on the same evaluation episodes.

The default run takes seconds and proves only that the pipeline works; for a real comparison
set ``NS_PZ_EXAMPLE_TIMESTEPS=200000`` (and ``NS_PZ_EXAMPLE_ALGO=SAC``, slower per step).
"""

import os
import sys

import mujoco

import ns_pz
from ns_pz.learn import TrainArgs, episode_returns, mean_and_se, train
from ns_pz.nature import ContinuousScheduler, IncrementUpdate, ScriptedNature

TIMESTEPS = int(os.environ.get("NS_PZ_EXAMPLE_TIMESTEPS", "512"))
ALGO = os.environ.get("NS_PZ_EXAMPLE_ALGO", "PPO")
EPISODE = 1000 if TIMESTEPS >= 100_000 else 100
DRIFT = 0.01  # kg per step: +1 kg over a short episode, +10 kg over Gymnasium's 1,000 steps

SMALL = {"PPO": {"n_steps": 128, "batch_size": 64, "n_epochs": 2}, "SAC": {"learning_starts": 100}}



def mujoco_warning(message: str) -> None:
    """Print MuJoCo's warnings but one, which this script cannot act on.

    Gymnasium's v5 model files set ``settotalmass``, which MuJoCo deprecates at every compile.
    """
    if "settotalmass" not in message:
        print(f"MuJoCo warning: {message}", file=sys.stderr)


mujoco.set_mju_user_warning(mujoco_warning)

nature = ScriptedNature({"torso_mass": IncrementUpdate(ContinuousScheduler(start=1), k=DRIFT)})
for level in ("none", "detailed"):
    env = ns_pz.make_gym(
        "ns_pz/HalfCheetah-v0", nature=nature, notification=level, max_episode_steps=EPISODE
    )
    args = TrainArgs(ALGO, TIMESTEPS, SMALL[ALGO] if TIMESTEPS < 100_000 else {})
    model = train(env, args, seed=0)
    mean, error = mean_and_se(episode_returns(env, model, range(100, 103)))
    print(f"{ALGO}, {TIMESTEPS} steps, notification={level:8s} return {mean:9.3f} ± {error:.3f}")
