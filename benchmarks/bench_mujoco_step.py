"""CPU time of one MuJoCo step: Gymnasium's own, the family's, with its info, and the view's.

Measured in CPU time of this process (``time.process_time``), not wall time, so that other
processes sharing the cores do not count; the cases run interleaved, round after round, and the
best round of each is kept. Every case steps the same zero actions from the same start for
``--steps`` steps (the family and the view never change θ here), so the physics is the same.

* ``raw``: Gymnasium's ``{task}-v5`` ``step``, unwrapped;
* ``family``: :meth:`MujocoFamily.step` (state load, Gymnasium's step, the instability check,
  state and info packed);
* ``family + info``: the same plus :meth:`MujocoFamily.info` (what the view reads each step);
* ``view``: ``ns_pz.make_gym(...).step`` (no nature: the Dict observation, clock, info); where
  an episode terminates the view resets (Gymnasium's env and the family step on), so its
  physics is not the others' after that.

Run: ``python benchmarks/bench_mujoco_step.py [--tasks InvertedPendulum Hopper] [--rounds 40]
[--steps 200]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np
from ns_pz.envs import mujoco_tasks

import ns_pz


def cases(task: str, steps: int) -> dict[str, Callable[[], None]]:
    """The timed cases of one task, each running ``steps`` steps from a fixed start."""
    env = gym.make(f"{task}-v5").unwrapped
    family = getattr(mujoco_tasks, f"{task}Family")()
    view = ns_pz.make_gym(f"ns_pz/{task}-v0", max_episode_steps=None)
    zero = np.zeros(env.action_space.shape, np.float32)
    theta = family.default_params()
    rng = np.random.default_rng(0)
    start = family.initial_state(np.random.default_rng(0))

    def raw() -> None:
        env.reset(seed=0)
        for _ in range(steps):
            env.step(zero)

    def run_family(info: bool) -> None:
        state = start
        for _ in range(steps):
            state = family.step(state, zero, theta, rng)[0]
            if info:
                family.info(state)

    def run_view() -> None:
        view.reset(seed=0)
        for _ in range(steps):
            if view.step(zero)[2]:  # terminated (the pole fell, the hopper tipped over)
                view.reset()

    return {
        "raw": raw,
        "family": lambda: run_family(False),
        "family + info": lambda: run_family(True),
        "view": run_view,
    }


def main() -> None:
    """Time every case of every task and print µs per step and the ratio to raw."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=["InvertedPendulum", "Hopper", "HalfCheetah"])
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    for task in args.tasks:
        timed = cases(task, args.steps)
        best = dict.fromkeys(timed, float("inf"))
        for _ in range(args.rounds):
            for name, case in timed.items():
                begin = time.process_time()
                case()
                best[name] = min(best[name], (time.process_time() - begin) / args.steps * 1e6)
        line = ", ".join(f"{n} {t:.1f} µs ({t / best['raw']:.2f}x)" for n, t in best.items())
        print(f"{task}: {line}", flush=True)


if __name__ == "__main__":
    main()
