"""Cost of Double DQN's gradient step and greedy action, by path, at the paper's network shapes.

Three paths of the same learner, which train the same bits (tests/test_ddqn.py):

* whole: the gradient step and the greedy action are one compiled call each, the products
  through NumPy's own OpenBLAS routines (numba, and NumPy's bundled OpenBLAS);
* elementwise: the products in NumPy, the target, Adam and the Polyak update compiled (numba);
* numpy: NumPy alone.

Each shape is the paper's Q-network of a family (inputs, hidden widths, actions) on a replay
buffer of random transitions (one-hot states for the grids, as in training), batch 64, one BLAS
thread; each figure is the median over ``--rounds`` rounds of ``--steps`` calls.

Run: ``python benchmarks/bench_ddqn_step.py`` (``--smoke`` for a seconds-long check that it runs).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from ns_pz.agents.learning import ddqn
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.ddqn import DoubleDQN, new_learner
from ns_pz.agents.learning.mlp import one_blas_thread
from ns_pz.agents.learning.replay import ReplayBuffer

#: family: (inputs, hidden, actions, one-hot inputs)
SHAPES = {
    "FrozenLake 4x4": (16, (64,), 4, True),
    "CliffWalking": (48, (128,), 4, True),
    "Bridge": (16, (64, 64), 4, True),
    "CartPole": (4, (64,), 2, False),
}


def filled_buffer(
    inputs: int, num_actions: int, one_hot: bool, rng: np.random.Generator
) -> ReplayBuffer:
    """A buffer of 5,000 random transitions."""
    buffer = ReplayBuffer(10_000, inputs)
    for _ in range(5_000):
        if one_hot:
            x, next_x = np.zeros((2, inputs), dtype=np.float32)
            x[rng.integers(inputs)], next_x[rng.integers(inputs)] = 1.0, 1.0
        else:
            x, next_x = rng.normal(size=(2, inputs)).astype(np.float32)
        reward, terminated = float(rng.random() < 0.1), bool(rng.random() < 0.05)
        buffer.add(x, int(rng.integers(num_actions)), reward, next_x, terminated)
    return buffer


def median_micros(call: Callable[[], object], steps: int, rounds: int) -> float:
    """Median over ``rounds`` of the mean µs of ``steps`` calls (after ``steps`` untimed ones)."""
    for _ in range(steps):
        call()
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(steps):
            call()
        times.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(times)


def measure(shape: tuple[Any, ...], path: str, steps: int, rounds: int) -> tuple[float, float]:
    """``(µs per replay step, µs per greedy action)`` on ``path``."""
    inputs, hidden, num_actions, one_hot = shape
    rng = np.random.default_rng(0)
    buffer = filled_buffer(inputs, num_actions, one_hot, rng)
    saved = ddqn.products_for, ddqn.compiled_step
    if path in ("elementwise", "numpy"):
        ddqn.products_for = lambda widths, rows: None  # type: ignore[assignment]
    if path == "numpy":
        ddqn.compiled_step = lambda: None  # type: ignore[assignment]
    try:
        learner: DoubleDQN = new_learner(inputs, num_actions, DDQNArgs(hidden=hidden), 0)
        states = [buffer.features[i] for i in range(64)]
        cycle = iter(range(1 << 62))
        step = median_micros(lambda: learner.replay_step(buffer, rng), steps, rounds)
        greedy = median_micros(lambda: learner.greedy(states[next(cycle) % 64]), steps, rounds)
    finally:
        ddqn.products_for, ddqn.compiled_step = saved
    return step, greedy


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="tiny run that checks it works")
    parser.add_argument("--steps", type=int, default=2000, help="calls per round")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    steps, rounds = (20, 1) if args.smoke else (args.steps, args.rounds)
    whole = ddqn.products_for([16, 64, 4], 64) is not None
    missing = "not available (numba or NumPy's OpenBLAS missing)"
    print(f"whole-step path {'available' if whole else missing}")
    paths = ("whole", "elementwise", "numpy") if whole else ("elementwise", "numpy")
    print(f"\n{'network':16s} {'path':12s} {'replay step µs':>15s} {'greedy µs':>10s}")
    with one_blas_thread():
        for name, shape in SHAPES.items():
            for path in paths:
                if path != "numpy" and ddqn.compiled_step() is None:
                    continue
                step, greedy = measure(shape, path, steps, rounds)
                print(f"{name:16s} {path:12s} {step:>15.1f} {greedy:>10.2f}")


if __name__ == "__main__":
    main()
