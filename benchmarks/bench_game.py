"""The game against nature, solved exactly: run times and the README's table.

Prints two tables:

1. **Run time of each solver** on FrozenLake 4x4 (p_0 = 0.7, H = 100) and CliffWalking (p_0 = 1,
   goal reward 100, H = 100 and 200), nature on the slip line every 0.05 with Lipschitz 0.1 and
   budget 0.6: the Shapley game (with how many stages needed an LP), nature's closed-loop best
   response to the stale policy, the agent's best response to nature's equilibrium strategy, and
   nature's open-loop best response (beam of 500).
2. **How exploitable each planner is**, for FrozenLake and the Bridge at the paper's p_0 = 0.7
   (H = 100) and Lipschitz bounds 0.05 / 0.1 / 0.2 (budget 0.6): the game value at ``detailed``,
   each planner's value against nature's best response (stale θ_0-optimal, snapshot replanning,
   the rectangular robust policy, RATS depth 3 and MCTS with 100 iterations at ``detailed``),
   and the bracket on the value of notification (:func:`blind_value_bounds`).

Undiscounted expected return from the start state. Run: ``python benchmarks/bench_game.py``
(``--smoke``: small horizons, seconds).
"""

from __future__ import annotations

import argparse
import functools
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from ns_pz.agents.exact import (
    agent_best_response,
    blind_value_bounds,
    equal_split,
    exploitability,
    nature_best_response,
    open_loop_best_response,
    robust_slip_solution,
    search_policy_on_grid,
    slip_line_grid,
    snapshot_policy_on_grid,
    solve_game,
    stale_policy,
)
from ns_pz.agents.search.mcts import uct
from ns_pz.agents.search.rats import rats
from ns_pz.envs.bridge import BridgeFamily, BridgeParams
from ns_pz.envs.cliff_walking import CliffWalkingFamily, CliffWalkingParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.nature import NatureConstraints

STEP, BUDGET = 0.05, 0.6


def timed(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and its wall time in seconds."""
    start = time.perf_counter()
    result = fn()
    return result, time.perf_counter() - start


def run_times(smoke: bool) -> None:
    """Table 1."""
    cases = [
        ("FrozenLake 4x4", FrozenLakeFamily(), FrozenLakeParams(slip=equal_split(0.7, 3)), 100),
        (
            "CliffWalking",
            CliffWalkingFamily(goal_reward=100.0),
            CliffWalkingParams(slip=(1.0, 0.0, 0.0, 0.0)),
            100,
        ),
        (
            "CliffWalking",
            CliffWalkingFamily(goal_reward=100.0),
            CliffWalkingParams(slip=(1.0, 0.0, 0.0, 0.0)),
            200,
        ),
    ]
    print("Run time of each solver (slip line every 0.05, Lipschitz 0.1, budget 0.6)")
    print(
        f"{'env':16} {'H':>4} {'stages':>9} {'LPs':>8} {'game s':>7} {'value':>9} "
        f"{'BR(nat) s':>9} {'BR(agent) s':>11} {'open-loop s':>11}"
    )
    for name, family, theta0, horizon in cases:
        horizon = 5 if smoke else horizon
        grid = slip_line_grid(theta0, STEP, NatureConstraints(lipschitz=0.1, budget=BUDGET))
        game, game_time = timed(lambda: solve_game(family, grid, horizon))  # noqa: B023
        stale = stale_policy(family, theta0, horizon)
        _, nature_time = timed(lambda: nature_best_response(family, stale, grid, horizon))  # noqa: B023
        _, agent_time = timed(lambda: agent_best_response(family, game.nature, grid, horizon))  # noqa: B023
        _, open_time = timed(
            lambda: open_loop_best_response(family, stale, grid, horizon, max_nodes=500)  # noqa: B023
        )
        print(
            f"{name:16} {horizon:>4} {game.stages:>9} {game.linear_programs:>8} {game_time:>7.2f} "
            f"{game.value:>9.4f} {nature_time:>9.2f} {agent_time:>11.2f} {open_time:>11.2f}"
        )


def planner_table(smoke: bool) -> None:
    """Table 2."""
    horizon = 6 if smoke else 100
    lipschitz_bounds = (0.1,) if smoke else (0.05, 0.1, 0.2)
    cases = [
        ("FrozenLake", FrozenLakeFamily(), FrozenLakeParams(slip=equal_split(0.7, 3))),
        ("Bridge", BridgeFamily(), BridgeParams(slip=equal_split(0.7, 3))),
    ]
    print()
    print(f"Value against nature's best response (p_0 = 0.7, H = {horizon}, budget {BUDGET})")
    print(
        f"{'env':10} {'L':>5} {'game':>7} {'stale':>7} {'snapshot':>8} {'robust':>7} "
        f"{'RATS':>7} {'MCTS':>7} {'V_none in':>17} {'notification in':>17}"
    )
    for name, family, theta0 in cases:
        for lipschitz in lipschitz_bounds:
            rng = np.random.default_rng(0)
            constraints = NatureConstraints(lipschitz=lipschitz, budget=BUDGET)
            grid = slip_line_grid(theta0, STEP, constraints)
            game = solve_game(family, grid, horizon)
            stale = stale_policy(family, theta0, horizon)
            robust = robust_slip_solution(
                family, theta0, horizon, lipschitz=lipschitz, budget=BUDGET
            ).policy
            policies = {
                "stale": stale,
                "snapshot": snapshot_policy_on_grid(family, grid, horizon),
                "robust": robust,
                "RATS": search_policy_on_grid(
                    family, grid, horizon, functools.partial(rats, depth=3), rng
                ),
                "MCTS": search_policy_on_grid(
                    family,
                    grid,
                    horizon,
                    functools.partial(uct, iterations=20 if smoke else 100, depth=50),
                    rng,
                    samples=1 if smoke else 3,
                ),
            }
            values = {
                key: exploitability(family, policy, grid, horizon, game=game).response_value
                for key, policy in policies.items()
            }
            bounds = blind_value_bounds(
                family, grid, horizon, {"stale": stale, "robust": robust}, game=game
            )
            low, high = bounds.notification_value
            print(
                f"{name:10} {lipschitz:>5.2f} {game.value:>7.3f} {values['stale']:>7.3f} "
                f"{values['snapshot']:>8.3f} {values['robust']:>7.3f} {values['RATS']:>7.3f} "
                f"{values['MCTS']:>7.3f} [{bounds.lower:>6.3f}, {bounds.upper:>6.3f}] "
                f"[{low:>6.3f}, {high:>6.3f}]"
            )


def main() -> None:
    """Print both tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="small horizons: a quick check")
    args = parser.parse_args()
    run_times(args.smoke)
    planner_table(args.smoke)


if __name__ == "__main__":
    main()
