r"""What a table's detector column (WD) costs: building its env, and each step with the detector.

For each spec named, the WD cells' environments are built and played by a fixed policy (a
balancing rule with 10 % random actions on CartPole, uniform actions elsewhere), each episode
cut at ``--steps``. Printed: the CPU milliseconds of ``spec.make_env`` for the first env of the
process and for later ones (a spec's detector is built and bound once per process), the CPU
microseconds per step (the env's step with the detector's work in it; the policy's is
negligible), and a digest of every notification the agent saw (flags and sizes), so two
versions of the code can be checked to detect alike.

Run::

    python benchmarks/bench_detector.py cartpole-continuous cliffwalking-single --seeds 3
"""

from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

from ns_pz.experiments import load_spec
from ns_pz.experiments.spec import DETECTOR, ExperimentSpec


def action_of(observation: dict, space_n: int, rng: np.random.Generator) -> int:
    """The fixed policy: a balancing rule on CartPole's 4-vector, else uniform."""
    state = np.asarray(observation["state"])
    if state.size == 4 and rng.random() > 0.1:
        return int(state[2] + 0.5 * state[3] + 0.05 * state[1] > 0)
    return int(rng.integers(space_n))


def measure(spec: ExperimentSpec, seeds: int, steps: int) -> str:
    """One line: make_env's first and later CPU ms, µs per step, the notifications' digest."""
    cells = [cell for cell in spec.cells() if cell.notification == DETECTOR]
    if not cells:
        raise SystemExit(f"{spec.name} has no detector column")
    start = time.process_time()
    spec.make_env(cells[0])
    first = time.process_time() - start
    digest = hashlib.sha256()
    made = played = 0
    making = stepping = 0.0
    for cell in cells:
        for seed in range(seeds):
            start = time.process_time()
            env = spec.make_env(cell)
            making += time.process_time() - start
            made += 1
            observation, _ = env.reset(seed=seed)
            rng = np.random.default_rng(seed)
            start = time.process_time()
            for _ in range(steps):
                action = action_of(observation, int(env.action_space.n), rng)
                observation, _, terminated, truncated, _ = env.step(action)
                digest.update(np.asarray(observation["env_change"]).tobytes())
                digest.update(np.asarray(observation["delta_change"]).tobytes())
                played += 1
                if terminated or truncated:
                    break
            stepping += time.process_time() - start
    return (
        f"{spec.name:24s} make_env {first * 1e3:7.2f} ms first, {making / made * 1e3:6.2f} ms "
        f"later; {played} steps, {stepping / played * 1e6:7.1f} us a step; "
        f"notifications {digest.hexdigest()[:16]}"
    )


def main() -> None:
    """Measure each spec named."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("specs", nargs="+", help="spec names or files with a detector column")
    parser.add_argument("--size", default="full", choices=["quick", "full"])
    parser.add_argument("--seeds", type=int, default=3, help="episodes per WD cell")
    parser.add_argument("--steps", type=int, default=600, help="steps per episode at most")
    args = parser.parse_args()
    for name in args.specs:
        print(measure(load_spec(name, args.size), args.seeds, args.steps), flush=True)


if __name__ == "__main__":
    main()
