"""RATS decisions, finite-horizon value iteration and the oracle's optimum row, measured in one run.

Prints three tables:

1. **RATS, one decision at depth 3** (γ = 0.99, L_p = τ = 1, p = 0.7) from the FrozenLake and
   Bridge start states, for each worst-case rule, memoised (a DAG over (state, depth)) and as a
   full tree; with ``ns_gym`` importable, NS-Gym's own RATS (``benchmark_algorithms.rats``) on
   the same state, and how often its decision agrees with ``dirac_support`` (the rule it
   implements) over every non-terminal FrozenLake state. Bridge: NS-Gym's Bridge env stores the
   slip vector in ``unwrapped.P`` where its RATS expects a transition table; what happens is
   printed.
2. **Finite-horizon value iteration**, 200 steps on CliffWalking: the backup alone and the
   oracle including its θ trajectory and outcome tables.
3. **The oracle's exact optimum** for the NS-Gym paper's single-change settings (p_0 = 0.7 for
   FrozenLake / Bridge, 1 for CliffWalking with goal reward 100; p -> 0.4 / 0.6 / 0.8 from
   transition 1, k = 1; horizons 100 / 200 / 200), beside the exact values of snapshot
   replanning (notification ``detailed``) and of the stale θ_0 policy (``none``). Undiscounted
   expected return from the start state.

Times are medians over repeats in one run. Run: ``python benchmarks/bench_exact.py``
(``--smoke``: one repeat, a seconds-long check that it runs). To include NS-Gym, run it with
NS-Gym's interpreter after installing ns_pz there
(``pip install --no-deps --force-reinstall <repo>``).
"""

from __future__ import annotations

import argparse
import functools
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from ns_pz.agents.exact import (
    backward_induction,
    equal_split,
    initial_theta,
    oracle_solution,
    policy_values,
    snapshot_policy,
    stale_policy,
    start_value,
    theta_trajectory,
)
from ns_pz.agents.search.rats import rats

import ns_pz
from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

VARIANTS = ("dirac_support", "wasserstein_direct", "wasserstein_lp")
SETTINGS = {  # env id -> (p_0, horizon, family kwargs)
    "ns_pz/FrozenLake-v0": (0.7, 100, {}),
    "ns_pz/CliffWalking-v0": (1.0, 200, {"goal_reward": 100.0}),
    "ns_pz/Bridge-v0": (0.7, 200, {}),
}


def median_seconds(fn: Callable[[], Any], repeats: int) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def slip_size(env_id: str) -> int:
    """Outcomes per action: 4 on CliffWalking, 3 on the others."""
    return 4 if "Cliff" in env_id else 3


def single_change_env(env_id: str, new_p: float, notification: str = "none") -> Any:
    """The paper's single change: p_0 -> new_p from transition 1 on."""
    p0, horizon, kwargs = SETTINGS[env_id]
    size = slip_size(env_id)
    rule = DistributionStepWiseUpdate(DiscreteScheduler({1}), [equal_split(new_p, size)])
    return ns_pz.make_gym(
        env_id,
        params={"slip": equal_split(p0, size)},
        nature=ScriptedNature({"slip": rule}),
        notification=notification,
        max_episode_steps=horizon,
        **kwargs,
    )


def model_at(env_id: str, p: float) -> Any:
    """A planning model at the start state under the equal-split slip vector of ``p``."""
    env = ns_pz.make_gym(env_id, params={"slip": equal_split(p, slip_size(env_id))})
    env.reset(seed=0)
    return env.planning_model()


# -- 1. RATS ------------------------------------------------------------------------------------
def nsgym_rats() -> Any:
    """NS-Gym's RATS class, or ``None`` without NS-Gym."""
    try:
        from ns_gym.benchmark_algorithms.rats import RATS
    except ImportError:
        return None
    return RATS


def nsgym_frozen_lake(p: float) -> Any:
    """NS-Gym's FrozenLake wrapper with slip [p, (1-p)/2, (1-p)/2] and no change."""
    import gymnasium as gym
    from ns_gym.schedulers import DiscreteScheduler as NGDiscrete
    from ns_gym.update_functions import DistributionNoUpdate
    from ns_gym.wrappers import NSFrozenLakeWrapper

    base = gym.make("FrozenLake-v1", is_slippery=False)
    update = DistributionNoUpdate(NGDiscrete({10_000}))
    env = NSFrozenLakeWrapper(base, {"P": update}, initial_prob_dist=list(equal_split(p, 3)))
    env.reset(seed=0)
    return env


def nsgym_bridge(p: float) -> Any:
    """NS-Gym's Bridge env (its map, global slip vector) wrapped as NS-Gym does."""
    import gymnasium as gym
    from ns_gym.schedulers import DiscreteScheduler as NGDiscrete
    from ns_gym.update_functions import DistributionNoUpdate
    from ns_gym.wrappers import NSBridgeWrapper

    base = gym.make("ns_gym/Bridge-v0")
    update = DistributionNoUpdate(NGDiscrete({10_000}))
    env = NSBridgeWrapper(base, {"P": update}, initial_prob_dist=list(equal_split(p, 3)))
    env.reset(seed=0)
    return env


def bench_rats(repeats: int) -> None:
    """Table 1."""
    print("RATS, one decision at depth 3 (γ .99, L_p = τ = 1, p = 0.7), ms per decision")
    print(f"{'env / state':24}{'worst case':22}{'DAG ms':>9}{'tree ms':>9}{'nodes':>12}  action")
    rng = np.random.default_rng(0)
    for env_id, state in (("ns_pz/FrozenLake-v0", 0), ("ns_pz/Bridge-v0", 20)):
        model = model_at(env_id, 0.7)
        for variant in VARIANTS:
            options = {"depth": 3, "gamma": 0.99, "worst_case": variant}
            dag = rats(model, state, rng, **options)
            tree = rats(model, state, rng, memoise=False, **options)
            if not np.array_equal(dag.values, tree.values):
                raise RuntimeError(f"DAG and tree disagree on {env_id} {variant}")
            decide = functools.partial(rats, model, state, rng, **options)
            dag_ms = 1e3 * median_seconds(decide, repeats)
            tree_ms = 1e3 * median_seconds(functools.partial(decide, memoise=False), repeats)
            nodes = f"{dag.stats['decision_nodes']}/{tree.stats['decision_nodes']}"
            name = f"{env_id.split('/')[1]} s={state}"
            print(f"{name:24}{variant:22}{dag_ms:9.3f}{tree_ms:9.3f}{nodes:>12}  {dag.action}")
    agent_cls = nsgym_rats()
    if agent_cls is None:
        print("NS-Gym not importable: no side-by-side RATS")
        return
    import gymnasium as gym

    env = nsgym_frozen_lake(0.7)
    agent = agent_cls(gym.spaces.Discrete(4), gamma=0.99, max_depth=3)
    ng_ms = 1e3 * median_seconds(lambda: agent.act(env=env), repeats)
    action = agent.act(env=env)
    print(f"{'FrozenLake-v0 s=0':24}{'NS-Gym RATS':22}{ng_ms:9.3f}{'':21}  {action}")
    model = model_at("ns_pz/FrozenLake-v0", 0.7)
    family = model.family
    agree, total, worst_gap = 0, 0, 0.0
    for state in range(16):
        if family.is_terminal_state(state):
            continue
        env.unwrapped.s = state
        root = agent.initialize_tree(env, False)  # what act() does, keeping the root values
        agent.minimax(root, env)
        theirs = np.array([child.value for child in root.children])
        ours = rats(model, state, rng, depth=3, gamma=0.99, worst_case="dirac_support")
        worst_gap = max(worst_gap, float(np.max(np.abs(theirs - ours.values))))
        agree += int(agent.act(env=env) == ours.action)
        total += 1
    print(
        f"  NS-Gym RATS vs dirac_support on FrozenLake: same action in {agree}/{total} "
        f"non-terminal states, largest root-value difference {worst_gap:.2e}"
    )
    try:
        bridge = nsgym_bridge(0.7)
        action = agent.act(env=bridge)
        print(f"  NS-Gym RATS on NS-Gym's Bridge: action {action}")
    except Exception as error:  # report whatever NS-Gym raises, as it is
        print(f"  NS-Gym RATS on NS-Gym's Bridge fails: {type(error).__name__}: {error}")


# -- 2. Finite-horizon VI -----------------------------------------------------------------------
def bench_value_iteration(repeats: int) -> None:
    """Table 2."""
    env_id = "ns_pz/CliffWalking-v0"
    env = single_change_env(env_id, 0.6)
    family = env.family
    tables = [family.outcomes(theta) for theta in theta_trajectory(env, 0)]
    induction = median_seconds(lambda: backward_induction(tables), repeats)
    oracle = median_seconds(lambda: oracle_solution(family, theta_trajectory(env, 0)), repeats)
    print("\nFinite-horizon value iteration, CliffWalking 4x12, H = 200, 4 actions x 4 outcomes")
    print(f"  backward induction alone:              {1e3 * induction:8.2f} ms")
    print(f"  oracle incl. θ trajectory and tables:  {1e3 * oracle:8.2f} ms")


# -- 3. The optimum row -------------------------------------------------------------------------
def bench_optimum() -> None:
    """Table 3."""
    print("\nExact expected return from the start, single change at transition 1 (k = 1)")
    print(f"{'env':18}{'p_0':>5}{'H':>5}{'p_new':>7}{'oracle':>12}{'snapshot':>12}{'stale':>12}")
    for env_id, (p0, horizon, _) in SETTINGS.items():
        for new_p in (0.4, 0.6, 0.8):
            env = single_change_env(env_id, new_p)
            family, thetas = env.family, theta_trajectory(env, 0)
            oracle = start_value(family, oracle_solution(family, thetas).values)
            snap = policy_values(
                family, thetas, snapshot_policy(family, initial_theta(env), thetas)
            )
            stale = policy_values(family, thetas, stale_policy(family, initial_theta(env), horizon))
            print(
                f"{env_id.split('/')[1]:18}{p0:5.1f}{horizon:5d}{new_p:7.1f}{oracle:12.4f}"
                f"{start_value(family, snap):12.4f}{start_value(family, stale):12.4f}"
            )


def main() -> None:
    """Run the three benchmarks."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="one repeat: check that it runs")
    args = parser.parse_args()
    repeats = 1 if args.smoke else 21
    bench_rats(repeats)
    bench_value_iteration(repeats)
    bench_optimum()


if __name__ == "__main__":
    main()
