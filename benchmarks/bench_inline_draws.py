"""What drawing numpy's PCG64 inline saves compiled searches: draws, UCT and PUCT decisions.

The compiled kernels draw through :class:`~ns_pz.agents.search._pcg64.PCG64Stream` objects where
the generators are numpy's PCG64 (:func:`~ns_pz.agents.search._pcg64.inline_streams`). This
measures, in one process, each path against the same path drawing through the
``numpy.random.Generator`` objects themselves (numba's call through the bit generator's
function pointer), the two alternated:

* one ``random()`` draw in a compiled loop (least of 5 runs of 10 million draws);
* one UCT decision from the start state at ``bench_search.py``'s settings (FrozenLake m=100,
  CliffWalking m=1000 deterministic, CartPole m=300 at γ = 0.5 and 1) and on CliffWalking with
  the slip 0.4/0.2/0.2/0.2 of the paper's cells; the same seeds both ways;
* one AlphaZero PUCT decision on CartPole at the specs' full size (500 simulations, trunk
  128-128, random weights, the network's memo cleared).

Each decision figure is the least of ``--rounds`` medians of ``--repeats`` decisions, and each
decision is checked to give the same result and to leave both generators in the same state both
ways. Run: ``python benchmarks/bench_inline_draws.py`` (``--smoke`` for a quick check).
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time
from collections.abc import Callable, Iterator
from typing import Any
from unittest import mock

import numpy as np
from bench_search import SETTINGS, alphazero_decision
from ns_pz.agents.search.compiled import kernels, numba_available
from ns_pz.agents.search.mcts import uct

SLIPPERY_CLIFF = {
    "id": "ns_pz/CliffWalking-v0",
    "kwargs": {"goal_reward": 100.0, "params": {"slip": (0.4, 0.2, 0.2, 0.2)}},
    "m": 1000,
    "d": 200,
    "gamma": 0.999,
}


@contextlib.contextmanager
def through_generators() -> Iterator[None]:
    """The kernels draw through the Generators, as before :mod:`._pcg64`."""
    with mock.patch.object(kernels(), "inline_streams", lambda *generators: generators):
        yield


def ns_per_draw(draws: int) -> tuple[float, float]:
    """``(Generator, stream)`` nanoseconds per ``random()`` in a compiled summing loop."""
    import numba
    from ns_pz.agents.search._pcg64 import inline_streams

    @numba.njit
    def total(rng: Any, count: int) -> float:
        value = 0.0
        for _ in range(count):
            value += rng.random()
        return value

    generator = np.random.default_rng(0)
    (stream,) = inline_streams(np.random.default_rng(0))
    total(generator, 10)
    total(stream, 10)
    best = [np.inf, np.inf]
    for _ in range(5):
        for k, rng in enumerate((generator, stream)):
            start = time.perf_counter()
            total(rng, draws)
            best[k] = min(best[k], (time.perf_counter() - start) / draws * 1e9)
    return best[0], best[1]


def uct_decision(setting: dict[str, Any]) -> Callable[[int], tuple[Any, ...]]:
    """A UCT decision from the start state, seeded by ``i``: its result and generators' states."""
    import ns_pz

    env = ns_pz.make_gym(setting["id"], **setting["kwargs"])
    env.reset(seed=0)
    model = env.planning_model()
    root = model.get_state()

    def decide(i: int) -> tuple[Any, ...]:
        model.rng = np.random.default_rng(i)
        search_rng = np.random.default_rng(10_000 + i)
        result = uct(
            model,
            root,
            search_rng,
            iterations=setting["m"],
            depth=setting["d"],
            c=2**0.5,
            gamma=setting["gamma"],
            backend="compiled",
        )
        states = (model.rng.bit_generator.state, search_rng.bit_generator.state)
        return result.action, result.visits.tolist(), result.values.tolist(), states

    return decide


def compare(decide: Callable[[int], Any], repeats: int, rounds: int) -> tuple[float, float]:
    """``(Generator, stream)`` seconds: the least of ``rounds`` medians, paths alternated.

    Raises:
        AssertionError: The two paths' results or generator states differ.
    """
    for i in range(repeats):  # compile both, and check them against each other
        with through_generators():
            before = decide(i)
        if decide(i) != before:
            raise AssertionError(f"decision {i} differs between the two ways of drawing")
    best = [np.inf, np.inf]
    for _ in range(rounds):
        for k in (0, 1):
            times = []
            for i in range(repeats):
                with through_generators() if k == 0 else contextlib.nullcontext():
                    start = time.perf_counter()
                    decide(i)
                    times.append(time.perf_counter() - start)
            best[k] = min(best[k], statistics.median(times))
    return best[0], best[1]


def _summary(result: Any) -> tuple[Any, ...]:
    return result.action, result.visits.tolist(), np.asarray(result.values).tolist()


def main() -> None:
    """Print the three comparisons."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="tiny run that checks it works")
    parser.add_argument("--repeats", type=int, default=20, help="decisions per median")
    parser.add_argument("--rounds", type=int, default=3, help="medians per path (least kept)")
    args = parser.parse_args()
    if not numba_available():
        raise SystemExit("numba is not installed: pip install 'ns_pz[fast]'")
    repeats, rounds = (2, 1) if args.smoke else (args.repeats, args.rounds)
    generator, stream = ns_per_draw(100_000 if args.smoke else 10_000_000)
    print(f"one random() in a compiled loop: Generator {generator:.2f} ns, stream {stream:.2f} ns")
    settings = {**SETTINGS, "CliffWalkingSlip0.4": SLIPPERY_CLIFF}
    print(f"\none decision (least of {rounds} medians of {repeats}; the same trees both ways)")
    print(f"  {'setting':32s} {'Generator':>10s} {'stream':>10s} {'saved':>7s}")
    decisions: dict[str, Callable[[int], Any]] = {
        f"UCT {name} (m={s['m']})": uct_decision(s) for name, s in settings.items()
    }
    alphazero = alphazero_decision("compiled", 0.02 if args.smoke else 1.0)
    decisions["PUCT CartPole (m=500)"] = lambda i: _summary(alphazero(i))
    if args.smoke:
        decisions = dict(list(decisions.items())[:1] + list(decisions.items())[-1:])
    for label, decide in decisions.items():
        slow, fast = compare(decide, repeats, rounds)
        saved = 1.0 - fast / slow
        print(f"  {label:32s} {slow * 1e3:8.2f} ms {fast * 1e3:7.2f} ms {saved:7.0%}")


if __name__ == "__main__":
    main()
