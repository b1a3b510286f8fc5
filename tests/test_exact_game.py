"""The exact game tools against brute force, against each other and against the oracle."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest
from ns_pz.agents.exact import (
    NatureGrid,
    agent_best_response,
    averaged_equilibrium,
    blind_value_bounds,
    equal_split,
    exploitability,
    nature_best_response,
    nature_grid,
    open_loop_best_response,
    oracle_solution,
    play_values,
    policy_values,
    robust_slip_solution,
    search_policy_on_grid,
    slip_line_grid,
    snapshot_policy,
    snapshot_policy_on_grid,
    solve_game,
    solve_matrix_games,
    stale_policy,
    start_value,
)
from ns_pz.agents.search.rats import rats
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.nature import NatureConstraints
from ns_pz.planning import TabularOutcomes


class PenniesFamily:
    """Two states (0 live, 1 absorbing); θ's intended probability p decides which action pays.

    Action 0 reaches the goal (+1, terminal) with probability p, action 1 with 1 - p; otherwise
    the agent stays. With p ∈ {0.2, 0.8} each step is a matching-pennies game.
    """

    params_cls = FrozenLakeParams
    start_states = (0,)

    def outcomes(self, theta: FrozenLakeParams) -> TabularOutcomes:
        """The table under θ."""
        p = theta.slip[0]
        probs = np.array([[[p, 1 - p], [1 - p, p]], [[1.0, 0.0], [1.0, 0.0]]])
        next_states = np.array([[[1, 0], [1, 0]], [[1, 1], [1, 1]]])
        rewards = np.array([[[1.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]]])
        terminals = np.array([[[True, False], [True, False]], [[True, True], [True, True]]])
        return TabularOutcomes(probs, next_states, rewards, terminals)


def theta(p: float) -> FrozenLakeParams:
    """FrozenLake θ with intended probability p, the tail split equally."""
    return FrozenLakeParams(slip=equal_split(p, 3))


def pennies_grid() -> NatureGrid:
    """Nature moves freely between p = 0.2 and p = 0.8, starting at 0.8."""
    return nature_grid([theta(0.2), theta(0.8)], theta(0.8))


def test_matrix_games_match_enumeration_of_mixed_strategies_on_2x2():
    """The LP value and strategies equal a fine enumeration of the row player's mixtures."""
    rng = np.random.default_rng(0)
    games = rng.normal(size=(50, 2, 2))
    solved = solve_matrix_games(games)
    mixtures = np.linspace(0.0, 1.0, 20001)
    for game, value, row in zip(games, solved.values, solved.rows, strict=True):
        guaranteed = np.minimum(
            mixtures * game[0, 0] + (1 - mixtures) * game[1, 0],
            mixtures * game[0, 1] + (1 - mixtures) * game[1, 1],
        )
        assert value == pytest.approx(guaranteed.max(), abs=1e-4)
        assert row[0] == pytest.approx(mixtures[guaranteed.argmax()], abs=1e-3) or np.isclose(
            guaranteed.max(), guaranteed.min()
        )
    assert solved.linear_programs > 0  # some of them have no pure saddle point


def test_matrix_games_strategies_are_optimal_and_respect_barred_columns():
    """Each side's strategy guarantees the value; nature never weights a barred column."""
    rng = np.random.default_rng(1)
    games = rng.normal(size=(3000, 4, 5))
    allowed = rng.random((3000, 5)) < 0.6
    allowed[:, 2] = True
    solved = solve_matrix_games(games, allowed)
    row_guarantee = np.where(allowed, np.einsum("na,naj->nj", solved.rows, games), np.inf)
    column_guarantee = np.einsum("naj,nj->na", games, solved.columns)
    np.testing.assert_allclose(row_guarantee.min(axis=1), solved.values, atol=1e-7)
    np.testing.assert_allclose(column_guarantee.max(axis=1), solved.values, atol=1e-7)
    assert np.all(solved.columns[~allowed] == 0.0)


@pytest.mark.parametrize("scale", [1e-12, 1e-9, 1.0, 1e6])
def test_matrix_games_are_solved_at_any_payoff_scale(scale):
    """[[3, 0], [1, 2]] × s: value 1.5 s, rows (1/4, 3/4), columns (1/2, 1/2).

    HiGHS's absolute tolerances gave 1.2e-9 and rows (0.4, 0.6) at s = 1e-9.
    """
    solved = solve_matrix_games(np.array([[[3.0, 0.0], [1.0, 2.0]]]) * scale)
    assert solved.values[0] == pytest.approx(1.5 * scale, rel=1e-9)
    assert solved.rows[0] == pytest.approx([0.25, 0.75], abs=1e-9)
    assert solved.columns[0] == pytest.approx([0.5, 0.5], abs=1e-9)


@pytest.mark.parametrize("far", [-1e3, -1e8])
def test_matrix_games_with_a_far_dominated_row_keep_their_accuracy(far):
    """A row never played, far from the others, does not swamp the game.

    Scaling every game to [0, 1] gave value 0 for -1e8.
    """
    solved = solve_matrix_games(np.array([[[3.0, 0.0], [1.0, 2.0], [far, far]]]))
    assert solved.values[0] == pytest.approx(1.5, abs=1e-12)
    assert solved.rows[0] == pytest.approx([0.25, 0.75, 0.0], abs=1e-9)


def test_matrix_games_far_from_zero_are_solved_around_their_value():
    """Payoffs offset by 1e9 (span 1): HiGHS failed on most such games unshifted."""
    rng = np.random.default_rng(0)
    for _ in range(20):
        game = rng.uniform(size=(5, 4))
        game = (game - game.min()) / (game.max() - game.min()) + 1e9
        solved = solve_matrix_games(game[None])
        guaranteed = (solved.rows[0] @ game).min()
        capped = (game @ solved.columns[0]).max()
        assert capped - guaranteed <= 1e-6  # float64 resolution at 1e9 is 1.2e-7
        assert guaranteed - 1e-6 <= solved.values[0] <= capped + 1e-6


def test_a_small_game_far_from_zero_is_not_taken_for_a_saddle_point():
    """Span 1e-3 at 1e9: the saddle test relative to |value| called it pure (gap half the span)."""
    game = np.array([[1.0, 0.0], [0.25, 0.75]]) * 1e-3 + 1e9
    solved = solve_matrix_games(game[None])
    assert solved.linear_programs == 1
    assert solved.columns[0] == pytest.approx([0.5, 0.5], abs=1e-3)


def test_matrix_games_reject_bad_input():
    """Shapes and a game without any column are caller errors."""
    with pytest.raises(ValueError, match=r"payoffs has shape \(2, 2\)"):
        solve_matrix_games(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="no allowed column"):
        solve_matrix_games(np.zeros((1, 2, 2)), np.zeros((1, 2), bool))


def test_slip_line_grid_encodes_lipschitz_and_budget():
    """Points every step from p_0; moves within L are allowed; costs are |Δp| in units."""
    grid = slip_line_grid(theta(0.7), 0.1, NatureConstraints(lipschitz=0.2, budget=0.3))
    ps = [t.slip[0] for t in grid.thetas]
    np.testing.assert_allclose(ps, np.arange(0.0, 1.0001, 0.1), atol=1e-12)
    assert grid.thetas[grid.start] == theta(0.7)
    assert grid.budget_levels == 4 and grid.full_budget == 3
    i = grid.start
    assert grid.allowed[i, i + 2] and not grid.allowed[i, i + 3]
    assert grid.costs[i, i - 2] == 2
    after = grid.next_budget()
    assert after[i, 3, i + 2] == 1 and after[i, 1, i + 2] == -1 and after[i, 0, i] == 0
    assert grid.feasible([i + 1, i + 2, i + 1]) and not grid.feasible([i + 2, i, i])


def test_grid_builders_reject_bad_input():
    """Off-line θ_0, a bad step, a budget not made of units, foreign θ: errors that say so."""
    with pytest.raises(ValueError, match="off the slip line"):
        slip_line_grid(FrozenLakeParams(slip=(0.5, 0.3, 0.2)), 0.1)
    with pytest.raises(ValueError, match="step=0 must be a number > 0"):
        slip_line_grid(theta(0.5), 0)
    with pytest.raises(ValueError, match="not a whole number of budget_unit"):
        nature_grid(
            [theta(0.5), theta(0.8)], theta(0.7), NatureConstraints(budget=1.0), budget_unit=0.2
        )
    with pytest.raises(TypeError, match="every θ must be a FrozenLakeParams"):
        nature_grid([object()], theta(0.5))  # type: ignore[list-item]
    with pytest.raises(ValueError, match="θ\\^0 has no move costing nothing"):
        NatureGrid((theta(0.5),), 0, np.zeros((1, 1), bool), np.zeros((1, 1), np.int64), 1, 1.0)


# -- brute force: the game tree, walked node by node ----------------------------------------


def tree_value(family, grid, horizon, agent, nature_choice=None):
    """Expected return by walking the game tree (no vectorisation, no stage tables).

    ``agent(t, s, i, b)`` gives action probabilities; nature either minimises at every node
    (``nature_choice=None``: any history-dependent nature, hence its best response) or plays
    ``nature_choice(t, s, i, b)`` (a grid index).
    """
    tables = [family.outcomes(th) for th in grid.thetas]
    after = grid.next_budget()

    @functools.cache
    def value(t, s, i, b):
        if t == horizon:
            return 0.0
        probs = agent(t, s, i, b)

        def if_nature_picks(j):
            table, total = tables[j], 0.0
            for a, pa in enumerate(probs):
                for k in range(table.probs.shape[2]):
                    p = table.probs[s, a, k]
                    if pa == 0.0 or p == 0.0:
                        continue
                    future = 0.0
                    if not table.terminals[s, a, k]:
                        future = value(t + 1, int(table.next_states[s, a, k]), j, after[i, b, j])
                    total += pa * p * (table.rewards[s, a, k] + future)
            return total

        if nature_choice is not None:
            return if_nature_picks(nature_choice(t, s, i, b))
        return min(if_nature_picks(j) for j in range(grid.size) if after[i, b, j] >= 0)

    starts = family.start_states
    return float(np.mean([value(0, s, grid.start, grid.full_budget) for s in starts]))


class RandomFamily:
    """A random tabular family: the table under θ mixes two random tables by p = θ.slip[0].

    Five states (the last absorbing), three actions, three outcomes per (state, action) with
    random next states, rewards and terminal flags; starts in 0 or 1.
    """

    params_cls = FrozenLakeParams
    start_states = (0, 1)

    def __init__(self, seed: int) -> None:
        rng = np.random.default_rng(seed)
        shape = (5, 3, 3)
        self.low = rng.dirichlet(np.ones(3), size=shape[:2])
        self.high = rng.dirichlet(np.ones(3), size=shape[:2])
        self.next_states = rng.integers(0, 5, size=shape)
        self.rewards = rng.normal(size=shape)
        self.terminals = rng.random(shape) < 0.15
        self.next_states[4], self.rewards[4], self.terminals[4] = 4, 0.0, True

    def outcomes(self, theta: FrozenLakeParams) -> TabularOutcomes:
        """The table under θ."""
        p = theta.slip[0]
        probs = p * self.high + (1 - p) * self.low
        return TabularOutcomes(probs, self.next_states, self.rewards, self.terminals)


def small_game(seed: int = 0):
    """A random family, p on {0, 0.2, ..., 1} from 0.8, Lipschitz 0.2, budget 0.4."""
    family = RandomFamily(seed)
    grid = slip_line_grid(theta(0.8), 0.2, NatureConstraints(lipschitz=0.2, budget=0.4))
    return family, grid


def random_policy(rng, horizon, grid, deterministic=True):
    """A random agent policy that reads θ_{t-1}: ``[H, 5, m]`` actions or probabilities."""
    if deterministic:
        return rng.integers(0, 3, size=(horizon, 5, grid.size))
    weights = rng.random((horizon, 5, grid.size, 3))
    return weights / weights.sum(axis=-1, keepdims=True)


def test_nature_best_response_matches_the_game_tree():
    """Closed-loop DP value = minimum over every history-dependent nature, walked in the tree."""
    rng = np.random.default_rng(1)
    horizon = 4
    for seed in range(3):
        family, grid = small_game(seed)
        for deterministic in (True, False):
            policy = random_policy(rng, horizon, grid, deterministic)
            strategy = np.eye(3)[policy] if deterministic else policy

            def agent(t, s, i, b, strategy=strategy):
                return strategy[t, s, i]

            response = nature_best_response(family, policy, grid, horizon)
            expected = tree_value(family, grid, horizon, agent)
            assert response.value == pytest.approx(expected, abs=1e-12)


def snapshot_like(family, grid, horizon):
    """``[H, S, m]``: the optimal policy of θ_{t-1} held fixed, per grid point."""
    return np.stack([stale_policy(family, th, horizon) for th in grid.thetas], axis=2)


def test_open_loop_best_response_matches_every_schedule_enumerated():
    """The exact open-loop search = the minimum of policy_values over all feasible schedules."""
    rng = np.random.default_rng(2)
    horizon = 4
    for seed in range(3):
        family, grid = small_game(seed)
        policy = random_policy(rng, horizon, grid)
        values = {}
        for path in itertools.product(range(grid.size), repeat=horizon):
            if not grid.feasible(path):
                continue
            seen = (grid.start, *path[:-1])  # the agent sees θ_{t-1}
            played = policy[np.arange(horizon), :, seen]
            schedule_values = policy_values(family, grid.schedule_of(path), played)
            values[path] = float(np.mean(schedule_values[0][list(family.start_states)]))
        response = open_loop_best_response(family, policy, grid, horizon)
        assert response.exact
        assert response.value == pytest.approx(min(values.values()), abs=1e-12)
        assert values[response.indices] == pytest.approx(response.value, abs=1e-12)
        closed = nature_best_response(family, policy, grid, horizon)
        assert closed.value <= response.value + 1e-12  # seeing the state never hurts nature


def test_open_loop_beam_gives_a_bracket():
    """A beam too narrow for the tree: value from a feasible schedule, lower bound closed-loop."""
    family, grid = small_game()
    horizon = 6
    policy = random_policy(np.random.default_rng(5), horizon, grid)
    exact = open_loop_best_response(family, policy, grid, horizon)
    beam = open_loop_best_response(family, policy, grid, horizon, max_nodes=3)
    assert exact.exact and not beam.exact
    assert beam.lower_bound <= exact.value + 1e-12 <= beam.value + 2e-12
    assert grid.feasible(beam.indices)
    with pytest.raises(ValueError, match="max_nodes=0 must be an int >= 1"):
        open_loop_best_response(family, policy, grid, horizon, max_nodes=0)


def test_best_response_value_is_below_every_sampled_nature():
    """Random schedules and random stochastic natures never do better for nature."""
    family, grid = small_game()
    horizon = 10
    rng = np.random.default_rng(3)
    policy = random_policy(rng, horizon, grid, deterministic=False)
    response = nature_best_response(family, policy, grid, horizon)
    allowed = grid.next_budget() >= 0
    for _ in range(30):
        weights = rng.random((horizon, 5, grid.size, grid.budget_levels, grid.size))
        weights = np.where(allowed[None, None], weights, 0.0)
        weights /= weights.sum(axis=-1, keepdims=True)
        values = play_values(family, policy, weights, grid, horizon)
        assert start_value_of(family, values, grid) >= response.value - 1e-12
    replayed = play_values(family, policy, response.choice, grid, horizon)
    assert start_value_of(family, replayed, grid) == pytest.approx(response.value, abs=1e-12)


def start_value_of(family, values, grid):
    """Start value at θ_{-1}, full budget."""
    return float(np.mean(values[0][list(family.start_states), grid.start, grid.full_budget]))


def test_agent_best_response_matches_every_deterministic_policy():
    """On the pennies game (H = 2), the agent's DP = the best of all deterministic policies."""
    family, grid = PenniesFamily(), pennies_grid()
    horizon = 2
    rng = np.random.default_rng(4)
    nature = rng.random((horizon, 2, grid.size, 1, grid.size))
    nature /= nature.sum(axis=-1, keepdims=True)
    response = agent_best_response(family, nature, grid, horizon)
    best = -np.inf
    # stages that matter: (t=0, s=0, i=start) and (t=1, s=0, i) for each i
    for first, second in itertools.product(range(2), itertools.product(range(2), repeat=2)):
        policy = np.zeros((horizon, 2, grid.size), np.int64)
        policy[0, 0, :] = first
        policy[1, 0, :] = second
        best = max(best, start_value_of(family, play_values(family, policy, nature, grid, 2), grid))
    assert response.value == pytest.approx(best, abs=1e-12)


def test_game_value_matches_the_normal_form_game():
    """Pennies, H = 2: Shapley's value = the LP value of the whole game in normal form."""
    from scipy.optimize import linprog

    family, grid = PenniesFamily(), pennies_grid()
    horizon = 2
    agents = list(itertools.product(range(2), itertools.product(range(2), repeat=2)))
    natures = list(itertools.product(range(2), itertools.product(range(2), repeat=2)))
    payoff = np.empty((len(agents), len(natures)))
    for r, (a0, a1) in enumerate(agents):
        for c, (j0, j1) in enumerate(natures):

            def agent(t, s, i, b, a0=a0, a1=a1):
                return np.eye(2)[a0 if t == 0 else a1[i]]

            def nature(t, s, i, b, j0=j0, j1=j1):
                return j0 if t == 0 else j1[i]

            payoff[r, c] = tree_value(family, grid, horizon, agent, nature)
    # max v  s.t.  x · payoff[:, c] >= v for every c, x a distribution
    rows, cols = payoff.shape
    result = linprog(
        np.r_[np.zeros(rows), -1.0],
        A_ub=np.c_[-payoff.T, np.ones(cols)],
        b_ub=np.zeros(cols),
        A_eq=np.r_[np.ones(rows), 0.0][None],
        b_eq=[1.0],
        bounds=[(0, None)] * rows + [(None, None)],
        method="highs",
    )
    solution = solve_game(family, grid, horizon)
    assert solution.linear_programs > 0  # the stages are mixed, not pure
    assert solution.value == pytest.approx(-result.fun, abs=1e-8)
    assert 0.2 < solution.value < 0.8


def test_equilibrium_is_unexploitable_on_frozen_lake():
    """Neither side gains by a best response to the other's equilibrium strategy."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.9), 0.1, NatureConstraints(lipschitz=0.1, budget=0.6))
    horizon = 15
    solution = solve_game(family, grid, horizon)
    against_agent = nature_best_response(family, solution.agent, grid, horizon)
    against_nature = agent_best_response(family, solution.nature, grid, horizon)
    assert against_agent.value == pytest.approx(solution.value, abs=1e-6)
    assert against_nature.value == pytest.approx(solution.value, abs=1e-6)
    np.testing.assert_allclose(against_agent.values, solution.values, atol=1e-6)
    # a planner that ignores nature does worse against its best response
    stale = nature_best_response(family, stale_policy(family, theta(0.9), horizon), grid, horizon)
    assert stale.value <= solution.value + 1e-9


def test_a_nature_with_one_schedule_gives_the_oracle_value():
    """A grid whose only path is θ_0 .. θ_{H-1}: the game is the oracle's MDP."""
    family = FrozenLakeFamily()
    schedule = [theta(p) for p in (0.9, 0.7, 0.5, 0.4, 0.6, 0.8)]
    points = (theta(1.0), *schedule)
    size = len(points)
    allowed = np.zeros((size, size), bool)
    allowed[np.arange(size - 1), np.arange(1, size)] = True  # forward along the chain only
    allowed[-1, -1] = True
    grid = NatureGrid(points, 0, allowed, np.zeros((size, size), np.int64), 1, np.inf)
    horizon = len(schedule)
    oracle = oracle_solution(family, schedule)
    expected = start_value(family, oracle.values)
    assert solve_game(family, grid, horizon).value == pytest.approx(expected, abs=1e-12)
    response = nature_best_response(family, oracle.policy, grid, horizon)
    assert response.value == pytest.approx(expected, abs=1e-12)
    stale = stale_policy(family, theta(1.0), horizon)
    assert nature_best_response(family, stale, grid, horizon).value == pytest.approx(
        start_value(family, policy_values(family, schedule, stale)), abs=1e-12
    )


def test_exploitability_of_the_equilibrium_is_zero_and_of_planners_positive():
    """The equilibrium strategy is not exploitable; the paper's planners are, by >= 0."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.9), 0.1, NatureConstraints(lipschitz=0.1, budget=0.3))
    horizon = 12
    game = solve_game(family, grid, horizon)
    assert exploitability(family, game.agent, grid, horizon, game=game).exploitability == (
        pytest.approx(0.0, abs=1e-6)
    )
    for policy in (
        stale_policy(family, theta(0.9), horizon),
        snapshot_policy_on_grid(family, grid, horizon),
        robust_slip_solution(family, theta(0.9), horizon, lipschitz=0.1, budget=0.3).policy,
    ):
        result = exploitability(family, policy, grid, horizon, game=game)
        assert result.exploitability >= -1e-9
        assert result.game_value == game.value
    with pytest.raises(ValueError, match="horizon 5 here, 12 in the game"):
        exploitability(family, game.agent[:5], grid, 5, game=game)


def test_a_game_solved_for_another_game_is_refused_where_it_is_reused():
    """Same sizes, another discount, grid or family: refused (they gave wrong values silently)."""
    family = FrozenLakeFamily()
    constraints = NatureConstraints(lipschitz=0.1, budget=0.3)
    grid = slip_line_grid(theta(0.9), 0.1, constraints)
    horizon = 4
    game = solve_game(family, grid, horizon, gamma=0.5)
    policy = stale_policy(family, theta(0.9), horizon)
    free = slip_line_grid(theta(0.9), 0.1, NatureConstraints(lipschitz=0.1))
    other_family = FrozenLakeFamily(reward_schedule=(2.0, 0.0, 0.0))
    for kwargs, match in [
        ({"gamma": 1.0}, "gamma 1.0 here, 0.5 in the game"),
        ({"gamma": 0.5, "grid": free}, "another grid"),
        ({"gamma": 0.5, "env": other_family}, "reward_schedule=\\(2.0, 0.0, 0.0\\)\\) here"),
    ]:
        call = {"env": family, "grid": grid, "gamma": 0.5, **kwargs}
        with pytest.raises(ValueError, match=match):
            exploitability(
                call["env"], policy, call["grid"], horizon, gamma=call["gamma"], game=game
            )
        with pytest.raises(ValueError, match=match):
            blind_value_bounds(
                call["env"],
                call["grid"],
                horizon,
                {"stale": policy},
                gamma=call["gamma"],
                game=game,
            )
    with pytest.raises(ValueError, match="another grid"):
        averaged_equilibrium(family, free, game)
    reused = exploitability(family, policy, grid, horizon, gamma=0.5, game=game)
    assert reused.game_value == game.value


def test_snapshot_policy_on_grid_plays_as_snapshot_replanning():
    """Against any schedule, the grid policy at θ_{t-1} is what snapshot_policy plays."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.7), 0.1, NatureConstraints(lipschitz=0.2))
    horizon = 8
    on_grid = snapshot_policy_on_grid(family, grid, horizon)
    path = [grid.start - 1, grid.start - 3, grid.start - 3, grid.start - 1] * 2
    seen = [grid.start, *path[:-1]]
    replayed = on_grid[np.arange(horizon), :, seen]
    schedule = grid.schedule_of(path)
    expected = snapshot_policy(family, grid.thetas[grid.start], schedule)
    np.testing.assert_array_equal(replayed, expected)


def test_search_policy_on_grid_records_the_planner_decisions():
    """A deterministic planner: one-hot at its decision per (state, θ), same for every t."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.8), 0.2, NatureConstraints(lipschitz=0.2), low=0.4)
    search = functools.partial(rats, depth=2, terminal_value="fl_hack")
    rng = np.random.default_rng(0)
    policy = search_policy_on_grid(family, grid, 5, search, rng)
    assert policy.shape == (5, 16, grid.size, 4)
    for i, point in enumerate(grid.thetas):
        model = family.planning_model(point, 4, rng)
        assert policy[3, 4, i].argmax() == search(model, 4, rng).action
    blind = search_policy_on_grid(family, grid, 5, search, rng, level="none")
    np.testing.assert_array_equal(blind, policy[:, :, grid.start])
    with pytest.raises(ValueError, match="level='full' is not a notification level"):
        search_policy_on_grid(family, grid, 5, search, rng, level="full")
    with pytest.raises(ValueError, match="samples=0 must be an int >= 1"):
        search_policy_on_grid(family, grid, 5, search, rng, samples=0)


def test_policy_and_nature_shapes_are_checked():
    """Wrong shapes and actions are caller errors naming what is allowed."""
    family, grid = small_game()
    with pytest.raises(ValueError, match=r"policy has integer shape \(3, 5, 2\)"):
        nature_best_response(family, np.zeros((3, 5, 2), np.int64), grid, 3)
    with pytest.raises(ValueError, match="policy holds actions outside 0..2"):
        nature_best_response(family, np.full((3, 5), 7), grid, 3)
    with pytest.raises(ValueError, match="nature puts weight on a move the grid bars"):
        agent_best_response(family, np.zeros((3, grid.size, grid.budget_levels), np.int64), grid, 3)
    with pytest.raises(TypeError, match="is not tabular"):
        solve_game(object(), grid, 3)


def test_blind_value_bounds_are_ordered_and_tight_on_one_schedule():
    """Lower <= upper <= detailed; a nature with one schedule leaves nothing to notify."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.9), 0.1, NatureConstraints(lipschitz=0.1, budget=0.3))
    horizon = 10
    stale = stale_policy(family, theta(0.9), horizon)
    bounds = blind_value_bounds(family, grid, horizon, {"stale": stale})
    assert bounds.lower <= bounds.upper + 1e-9 <= bounds.detailed + 2e-9
    assert bounds.lower >= bounds.candidate_values["stale"]
    low, high = bounds.notification_value
    assert 0.0 <= low + 1e-9 and low <= high + 1e-9
    points = (theta(1.0), theta(0.8), theta(0.6))
    allowed = np.array([[0, 1, 0], [0, 0, 1], [0, 0, 1]], bool)
    chain = NatureGrid(points, 0, allowed, np.zeros((3, 3), np.int64), 1, np.inf)
    bounds = blind_value_bounds(family, chain, 4, {"stale": stale[:4]})
    oracle = start_value(family, oracle_solution(family, [points[1], *[points[2]] * 3]).values)
    assert bounds.lower == pytest.approx(oracle, abs=1e-12)
    assert bounds.upper == pytest.approx(oracle, abs=1e-12)
    with pytest.raises(ValueError, match="a blind policy is"):
        blind_value_bounds(family, grid, horizon, {"snapshot": snapshot_like_grid(grid)})


def snapshot_like_grid(grid):
    """A policy that reads θ_{t-1}: not blind."""
    return np.zeros((10, 16, grid.size), np.int64)
