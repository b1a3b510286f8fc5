"""Cost of search: one MCTS decision, the model step in the rollout loop, and compile time.

Measured in one run on one machine:

* one UCT decision at the NS-Gym paper's settings: FrozenLake (m=100, d=100,
  γ=0.99, slip 0.7/0.15/0.15), CliffWalking (m=1000, d=200, γ=0.999, goal reward 100,
  deterministic), CartPole (m=300, d=500, γ=0.5) and CartPoleGamma1 (the same at γ=1, PA-MCTS's
  setting); ns_pz compiled (numba), ns_pz reference (pure Python) and, with ``ns_gym``
  importable, NS-Gym's ``MCTS`` on its planning env. Each figure is the median over repeated
  decisions from the start state;
* one AlphaZero (PUCT) decision on CartPole at the full size of the ``cartpole-*`` specs
  (500 simulations, depth 100, c=√2, γ=1, Q min-max scaled, no root noise) with a network of
  the CartPole shape (trunk (128, 128)) and random weights (PyTorch's default initialisation,
  seeded): compiled (the network inside the kernel), reference Python (whose forward pass is the
  kernel's where numba is installed) and reference Python with numpy's forward pass (the
  Python path as it was before the compiled one);
* compiled AlphaZero decisions along a CartPole episode (the search's own actions from the start
  state, 200 decisions or to the episode's end), with the network's memo of its last search
  kept (the default) and cleared before every decision, and the share of new nodes whose
  evaluation the memo held;
* the model step in the rollout loop, in ns per step: compiled rollouts (uniform random actions,
  no tree) against the reference loop over ``model.transition``;
* compile time: a fresh process's first compiled search with an empty numba cache, then again
  with the cache that run left (what every later process pays).

Run: ``python benchmarks/bench_search.py`` (``--smoke`` for a seconds-long check that it runs;
``--no-nsgym`` to skip NS-Gym even when installed; ``--envs CartPole`` for CartPole alone).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.puct import PolicyValueFunction, model_evaluation, puct
from ns_pz.agents.search.compiled import compile_model, kernels, numba_available
from ns_pz.agents.search.mcts import uct

import ns_pz

try:  # NS-Gym, for a side-by-side measurement when it is installed
    import gymnasium as gym
    import ns_gym.schedulers as ng_schedulers
    import ns_gym.update_functions as ng_updates
    import ns_gym.wrappers as ng_wrappers
    from ns_gym.benchmark_algorithms.MCTS import MCTS as NSGymMCTS
except ImportError:
    NSGymMCTS = None

SETTINGS: dict[str, dict[str, Any]] = {  # name: ns_pz id, env kwargs, m, d, gamma, NS-Gym setup
    "FrozenLake": {
        "id": "ns_pz/FrozenLake-v0",
        "kwargs": {"params": {"slip": (0.7, 0.15, 0.15)}},
        "m": 100,
        "d": 100,
        "gamma": 0.99,
    },
    "CliffWalking": {
        "id": "ns_pz/CliffWalking-v0",
        "kwargs": {"goal_reward": 100.0},
        "m": 1000,
        "d": 200,
        "gamma": 0.999,
    },
    "CartPole": {"id": "ns_pz/CartPole-v0", "kwargs": {}, "m": 300, "d": 500, "gamma": 0.5},
    # PA-MCTS's CartPole search: with γ = 1 UCT's paths run deep along the best line
    "CartPoleGamma1": {"id": "ns_pz/CartPole-v0", "kwargs": {}, "m": 300, "d": 500, "gamma": 1.0},
}


def planning_model(name: str, seed: int = 0) -> Any:
    """The ns_pz planning model of a setting at its start state."""
    setting = SETTINGS[name]
    env = ns_pz.make_gym(setting["id"], **setting["kwargs"])
    env.reset(seed=seed)
    return env.planning_model()


def time_decisions(decide: Callable[[int], object], repeats: int) -> float:
    """Median seconds of ``decide(i)`` over ``repeats`` calls."""
    times = []
    for i in range(repeats):
        start = time.perf_counter()
        decide(i)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def ns_pz_decision(name: str, backend: str, budget: float) -> Callable[[int], object]:
    """One ns_pz UCT decision from the start state, seeded by the call index."""
    setting = SETTINGS[name]
    model = planning_model(name)
    root = model.get_state()
    m = max(2, int(setting["m"] * budget))

    def decide(i: int) -> object:
        model.rng = np.random.default_rng(i)
        return uct(
            model,
            root,
            np.random.default_rng(10_000 + i),
            iterations=m,
            depth=setting["d"],
            c=2**0.5,
            gamma=setting["gamma"],
            backend=backend,
        )

    return decide


def nsgym_decision(name: str, budget: float) -> Callable[[int], object]:
    """One NS-Gym MCTS decision on its planning env at the start state (same m, d, c, γ)."""
    setting = SETTINGS[name]
    if setting["id"] == "ns_pz/CartPole-v0":
        update = ng_updates.NoUpdate(ng_schedulers.ContinuousScheduler())
        env = ng_wrappers.NSClassicControlWrapper(gym.make("CartPole-v1"), {"masspole": update})
    else:
        update = ng_updates.DistributionNoUpdate(ng_schedulers.ContinuousScheduler())
        if name == "FrozenLake":
            env = ng_wrappers.NSFrozenLakeWrapper(
                gym.make("FrozenLake-v1"),
                {"P": update},
                initial_prob_dist=list(setting["kwargs"]["params"]["slip"]),
            )
        else:
            env = ng_wrappers.NSCliffWalkingWrapper(
                gym.make("CliffWalking-v1"),
                {"P": update},
                initial_prob_dist=[1.0, 0.0, 0.0, 0.0],
                modified_rewards={"H": -100, "G": 100, "F": -1, "S": -1},
            )
    observation, _ = env.reset(seed=0)
    m = max(2, int(setting["m"] * budget))

    def decide(i: int) -> object:
        agent = NSGymMCTS(env.get_planning_env(), observation, setting["d"], m, 2**0.5,
                          setting["gamma"])  # fmt: skip
        return agent.search()

    return decide


def measure_decisions(names: list[str], budget: float, repeats: int, nsgym: bool) -> None:
    """Print one UCT decision's time per setting and implementation."""
    print(f"\nOne MCTS decision from the start state (median of {repeats}; NS-Gym: fewer)")
    print(f"  {'setting':34s} {'compiled':>11s} {'reference':>11s} {'NS-Gym':>11s} "
          f"{'NS-Gym/compiled':>16s}")  # fmt: skip
    for name in names:
        setting = SETTINGS[name]
        m = max(2, int(setting["m"] * budget))
        label = f"{name} m={m} d={setting['d']} γ={setting['gamma']}"
        compiled = reference = other = float("nan")
        if numba_available():
            decide = ns_pz_decision(name, "compiled", budget)
            decide(0)  # compile or load the kernels outside the timing
            compiled = time_decisions(decide, repeats)
        reference = time_decisions(ns_pz_decision(name, "python", budget), max(1, repeats // 5))
        if nsgym:
            other = time_decisions(nsgym_decision(name, budget), 1 if m >= 1000 else 3)
        ratio = "-" if other != other or compiled != compiled else f"{other / compiled:.0f}x"
        print(
            f"  {label:34s} {_ms(compiled):>11s} {_ms(reference):>11s} {_ms(other):>11s} "
            f"{ratio:>16s}"
        )


def random_policy_value(space: Any, hidden: tuple[int, ...], num_actions: int) -> Any:
    """A policy/value network with PyTorch's default initialisation (uniform ±1/√fan_in)."""
    rng = np.random.default_rng(0)
    sizes = [int(np.prod(space.shape)), *hidden]
    weights: dict[str, np.ndarray] = {}

    def layer(name: str, inputs: int, outputs: int) -> None:
        bound = 1.0 / np.sqrt(inputs)
        weights[f"{name}.weight"] = rng.uniform(-bound, bound, size=(outputs, inputs))
        weights[f"{name}.bias"] = rng.uniform(-bound, bound, size=outputs)

    for i in range(len(hidden)):
        layer(f"trunk.{i}", sizes[i], sizes[i + 1])
    layer("policy.0", hidden[-1], num_actions)
    layer("value.0", hidden[-1], 1)
    return PolicyValueFunction(weights, space)


def alphazero_decision(
    backend: str, budget: float, numpy_forward: bool = False
) -> Callable[[int], object]:
    """One PUCT decision on CartPole's start state at the specs' full size, seeded by ``i``.

    ``numpy_forward``: evaluate with ``PolicyValueFunction.__call__`` (numpy) rather than
    ``model_evaluation`` (the kernel's forward pass where numba is installed).
    """
    model = planning_model("CartPole")
    family = model.family
    args = AlphaZeroArgs().for_family(family)  # the paper's CartPole c, γ, trunk
    iterations = max(2, int(500 * budget))
    settings = dataclasses.replace(args.puct_settings(), iterations=iterations)
    function = random_policy_value(family.observation_space, args.hidden or (), 2)
    evaluate = model_evaluation(function, model)
    if numpy_forward:
        evaluate = lambda state: function(family.observe(state))  # noqa: E731
    root = model.get_state()

    def decide(i: int) -> object:
        function.search_memo = None  # a fresh decision: nothing remembered of the last one
        return puct(model, root, np.random.default_rng(i), evaluate, settings, backend)

    return decide


def alphazero_episode(budget: float, steps: int, remember: bool) -> tuple[float, float]:
    """Compiled PUCT decisions along one CartPole episode: ``(mean seconds, share remembered)``.

    The episode plays the search's action from the start state for ``steps`` decisions (or
    until it ends); ``remember=False`` clears the network's memo of the last search before each
    decision, so every node is evaluated.
    """
    env = ns_pz.make_gym(SETTINGS["CartPole"]["id"], **SETTINGS["CartPole"]["kwargs"])
    env.reset(seed=0)
    family = env.family
    args = AlphaZeroArgs().for_family(family)
    settings = dataclasses.replace(args.puct_settings(), iterations=max(2, int(500 * budget)))
    function = random_policy_value(family.observation_space, args.hidden or (), 2)
    rng = np.random.default_rng(0)
    seconds, nodes, remembered, decisions = 0.0, 0, 0, 0
    for _ in range(steps):
        model = env.planning_model()
        if not remember:
            function.search_memo = None
        start = time.perf_counter()
        result = puct(model, model.get_state(), rng, model_evaluation(function, model), settings)
        seconds += time.perf_counter() - start
        decisions += 1
        nodes += int(result.stats["nodes"]) - 1
        remembered += int(result.stats["remembered"])
        _, _, terminated, truncated, _ = env.step(result.action)
        if terminated or truncated:
            break
    return seconds / decisions, remembered / max(1, nodes)


def forward_pass_seconds(inputs: int, rounds: int = 5) -> float:
    """One forward pass of the CartPole search's network in a compiled loop (best of rounds).

    The network has the specs' full-size trunk and random weights; the inputs are CartPole-like
    states rounded to float32, as the search hands them over.
    """
    import numba
    from ns_pz.agents.learning import _puct_kernels as puct_kernels

    family = planning_model("CartPole").family
    args = AlphaZeroArgs().for_family(family)
    weights, layout, parts = random_policy_value(
        family.observation_space, args.hidden or (), 2
    ).packed()
    rng = np.random.default_rng(0)
    states = rng.normal(size=(inputs, 4)) * np.array([1.0, 2.0, 0.2, 2.0])
    states = states.astype(np.float32).astype(np.float64)

    @numba.njit
    def passes(weights, layout, parts, states):  # type: ignore[no-untyped-def]
        scratch, nonzero = puct_kernels.network_scratch(layout, states.shape[1])
        priors = np.empty(2)
        total = 0.0
        for i in range(states.shape[0]):
            total += puct_kernels.network_into(
                weights, layout, parts, states[i], priors, scratch, nonzero
            )
        return total

    passes(weights, layout, parts, states[:2])  # compile outside the timing
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        passes(weights, layout, parts, states)
        best = min(best, time.perf_counter() - start)
    return best / inputs


def measure_alphazero(budget: float, repeats: int) -> None:
    """Print one AlphaZero decision's time on CartPole, compiled and reference."""
    m = max(2, int(500 * budget))
    print(f"\nOne AlphaZero (PUCT) decision on CartPole from the start state (median of {repeats})")
    print(
        f"  {'setting':30s} {'compiled':>10s} {'reference':>10s} {'ref. numpy net':>15s} "
        f"{'ref./compiled':>14s}"
    )
    compiled = float("nan")
    if numba_available():
        decide = alphazero_decision("compiled", budget)
        decide(0)  # compile or load the kernels outside the timing
        compiled = time_decisions(decide, repeats)
    decide = alphazero_decision("python", budget)
    decide(0)  # the Python path's forward pass is compiled code too where numba is installed
    reference = time_decisions(decide, max(1, repeats // 4))
    numpy_net = time_decisions(alphazero_decision("python", budget, True), max(1, repeats // 4))
    ratio = "-" if compiled != compiled else f"{reference / compiled:.0f}x"
    label = f"CartPole m={m} d=100 c=√2 γ=1"
    print(
        f"  {label:30s} {_ms(compiled):>10s} {_ms(reference):>10s} {_ms(numpy_net):>15s} "
        f"{ratio:>14s}"
    )
    if not numba_available():
        return
    steps = 10 if budget < 1.0 else 200
    print(f"\nCompiled AlphaZero decisions along a CartPole episode ({steps} or to its end)")
    print(f"  {'memo of the last search':30s} {'decision':>10s} {'nodes found in it':>18s}")
    for remember in (False, True):
        seconds, share = alphazero_episode(budget, steps, remember)
        label = "kept" if remember else "cleared before each decision"
        print(f"  {label:30s} {_ms(seconds):>10s} {share:>17.0%}")
    inputs = 2_000 if budget < 1.0 else 20_000
    seconds = forward_pass_seconds(inputs)
    print(f"\nIts network's forward pass alone (compiled, {inputs} inputs): {seconds * 1e6:.2f} µs")


def measure_steps(names: list[str], steps: int) -> None:
    """Print ns per model step in the rollout loop, compiled and reference."""
    print(f"\nModel step in the rollout loop (uniform random actions, ~{steps} steps)")
    print(f"  {'model':14s} {'compiled ns':>12s} {'reference ns':>13s} {'ratio':>7s}")
    for name in names:
        model = planning_model(name)
        root = model.get_state()
        depth = SETTINGS[name]["d"]
        compiled_ns = float("nan")
        if numba_available():
            sim = compile_model(model, "compiled")
            vector = sim.family.to_vector(root)
            rng = np.random.default_rng(1)
            run = kernels().repeated_rollouts
            run(sim.data, vector, 2, sim.num_actions, depth, 0.99, rng, rng)  # compile / load
            count, total, elapsed = 64, 0, 0.0
            while total < steps:
                start = time.perf_counter()
                _, taken = run(sim.data, vector, count, sim.num_actions, depth, 0.99, rng, rng)
                elapsed += time.perf_counter() - start
                total += int(taken)
                count *= 2
            compiled_ns = elapsed / total * 1e9
        reference_ns = _reference_step_ns(model, root, depth, max(steps // 20, 1000))
        print(
            f"  {name:14s} {compiled_ns:12.1f} {reference_ns:13.1f} "
            f"{reference_ns / compiled_ns:6.0f}x"
        )


def _reference_step_ns(model: Any, root: Any, depth: int, steps: int) -> float:
    rng = np.random.default_rng(2)
    num_actions = int(model.action_space.n)
    transition = model.transition
    total, start = 0, time.perf_counter()
    while total < steps:
        state = root
        for _ in range(depth):
            state, _, done = transition(
                state, min(int(rng.random() * num_actions), num_actions - 1)
            )
            total += 1
            if done:
                break
    return (time.perf_counter() - start) / total * 1e9


COMPILE_SNIPPET = """
import time
start = time.perf_counter()
import numpy as np, ns_pz
from ns_pz.agents.search import uct
for env_id in ("ns_pz/FrozenLake-v0", "ns_pz/CartPole-v0"):
    env = ns_pz.make_gym(env_id); env.reset(seed=0); model = env.planning_model()
    uct(model, model.get_state(), np.random.default_rng(0), iterations=5, depth=5,
        backend="compiled")
print(time.perf_counter() - start)
"""


def measure_compile() -> None:
    """Print the first compiled searches' time in fresh processes: cold cache, then warm."""
    print(
        "\nCompile time (fresh process: import ns_pz + first compiled search, tabular + CartPole)"
    )
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as cwd:
        env = {**os.environ, "NS_PZ_CACHE_DIR": cache}
        for label in ("empty cache", "warm cache"):
            out = subprocess.run(
                [sys.executable, "-c", COMPILE_SNIPPET],
                capture_output=True, text=True, check=True, env=env, cwd=cwd,
            )  # fmt: skip
            print(f"  {label:12s} {float(out.stdout.strip()):6.2f} s")


def _ms(seconds: float) -> str:
    return "-" if seconds != seconds else f"{seconds * 1e3:.2f} ms"


def main() -> None:
    """Run every measurement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="tiny run that checks it works")
    parser.add_argument("--no-nsgym", action="store_true", help="skip NS-Gym even if installed")
    parser.add_argument("--repeats", type=int, default=20, help="compiled decisions per setting")
    parser.add_argument(
        "--envs", nargs="+", choices=sorted(SETTINGS), default=list(SETTINGS), help="settings"
    )
    args = parser.parse_args()
    nsgym = NSGymMCTS is not None and not args.no_nsgym and not args.smoke
    print(
        f"ns_pz {ns_pz.__version__}, numba "
        f"{'present' if numba_available() else 'not installed (compiled path skipped)'}, "
        f"NS-Gym {'present' if NSGymMCTS is not None else 'not installed (skipped)'}"
    )
    budget, repeats, steps = (0.05, 2, 20_000) if args.smoke else (1.0, args.repeats, 2_000_000)
    measure_decisions(args.envs, budget, repeats, nsgym)
    if "CartPole" in args.envs:
        measure_alphazero(budget, repeats)
    measure_steps(args.envs, steps)
    if numba_available() and not args.smoke:
        measure_compile()


if __name__ == "__main__":
    main()
