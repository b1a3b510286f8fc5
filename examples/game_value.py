"""How much can an adversarial nature take from each planner? The game's value, exactly.

Nature moves FrozenLake's slip probability on a grid (every 0.05, at most 0.1 per step, 0.6
in all) and sees the agent's state; the agent sees θ_{t-1} (notification ``detailed``). The
game value is what the best agent guarantees; each planner's value against nature's best
response shows how exploitable it is.
"""

from ns_pz.agents.exact import (
    equal_split,
    exploitability,
    robust_slip_solution,
    slip_line_grid,
    snapshot_policy_on_grid,
    solve_game,
    stale_policy,
)
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.nature import NatureConstraints

family = FrozenLakeFamily()
theta0 = FrozenLakeParams(slip=equal_split(0.7, 3))
horizon = 30
grid = slip_line_grid(theta0, 0.05, NatureConstraints(lipschitz=0.1, budget=0.6))

game = solve_game(family, grid, horizon)
print(f"game value: {game.value:.3f} ({game.linear_programs} of {game.stages} stages mixed)")
planners = {
    "stale θ_0-optimal": stale_policy(family, theta0, horizon),
    "snapshot replanning": snapshot_policy_on_grid(family, grid, horizon),
    "robust (rectangular)": robust_slip_solution(
        family, theta0, horizon, lipschitz=0.1, budget=0.6
    ).policy,
    "equilibrium": game.agent,
}
for name, policy in planners.items():
    result = exploitability(family, policy, grid, horizon, game=game)
    print(
        f"{name:22} value vs best-responding nature {result.response_value:.3f}, "
        f"exploitability {result.exploitability:.3f}"
    )
