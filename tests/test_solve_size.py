"""Every exact solve estimates its size up front, refuses beyond a limit, and can show progress."""

from __future__ import annotations

import time
import tracemalloc

import numpy as np
import pytest
from ns_pz.agents.exact import (
    agent_best_response,
    blind_value_bounds,
    equal_split,
    exploitability,
    nature_best_response,
    nature_grid,
    open_loop_best_response,
    play_values,
    slip_line_grid,
    solve_game,
    stale_policy,
)
from ns_pz.agents.exact.solve_size import SolveSize
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.nature import NatureConstraints


def theta(p: float) -> FrozenLakeParams:
    """FrozenLake θ with intended probability p, the tail split equally."""
    return FrozenLakeParams(slip=equal_split(p, 3))


def small():
    """4x4 lake, slip every 0.1 from 0.7, Lipschitz 0.1, budget 0.3, H = 5."""
    grid = slip_line_grid(theta(0.7), 0.1, NatureConstraints(lipschitz=0.1, budget=0.3))
    return FrozenLakeFamily(), grid, 5


def test_a_solve_beyond_the_memory_limit_is_refused_with_its_estimate_before_it_starts():
    """Step 0.00625 with a budget: one step did not fit 4 GiB; now refused at once."""
    family = FrozenLakeFamily()
    grid = slip_line_grid(theta(0.7), 0.00625, NatureConstraints(budget=0.6))
    started = time.monotonic()
    with pytest.raises(
        ValueError,
        match=r"solve_game is too large: 16 states × 161 θ × 97 budget levels × 20 steps = "
        r"4,997,440 stages, .* GiB at peak, beyond max_bytes=4294967296 \(4.0 GiB\)",
    ):
        solve_game(family, grid, 20)
    assert time.monotonic() - started < 5.0


def stay(grid, horizon):
    """Nature's ``[H, m, levels]`` grid indices that never move."""
    return np.tile(np.arange(grid.size)[None, :, None], (horizon, 1, grid.budget_levels))


@pytest.mark.parametrize(
    "solve",
    [
        lambda f, g, h, **k: solve_game(f, g, h, **k),
        lambda f, g, h, **k: nature_best_response(f, np.zeros((h, 16), np.int64), g, h, **k),
        lambda f, g, h, **k: open_loop_best_response(f, np.zeros((h, 16), np.int64), g, h, **k),
        lambda f, g, h, **k: agent_best_response(f, stay(g, h), g, h, **k),
        lambda f, g, h, **k: play_values(f, np.zeros((h, 16), np.int64), stay(g, h), g, h, **k),
        lambda f, g, h, **k: exploitability(f, np.zeros((h, 16), np.int64), g, h, **k),
        lambda f, g, h, **k: blind_value_bounds(
            f, g, h, {"stale": np.zeros((h, 16), np.int64)}, **k
        ),
    ],
    ids=["game", "nature", "open_loop", "agent", "play", "exploitability", "blind"],
)
def test_every_solver_takes_a_memory_limit(solve):
    """max_bytes is a parameter of every solver; nothing runs past it."""
    family, grid, horizon = small()
    with pytest.raises(ValueError, match=r"is too large: 16 states × 11 θ × 4 budget levels"):
        solve(family, grid, horizon, max_bytes=10_000)
    with pytest.raises(ValueError, match="max_bytes=0 must be > 0"):
        solve(family, grid, horizon, max_bytes=0)
    solve(family, grid, horizon, max_bytes=64 * 2**20)  # the estimate fits: it runs


def test_the_estimate_covers_the_measured_peak_without_crying_wolf():
    """The peak tracemalloc sees (numpy reports to it) is between half the estimate and all."""
    family = FrozenLakeFamily(map_name="8x8")
    grid = slip_line_grid(theta(0.7), 0.1, NatureConstraints(lipschitz=0.1, budget=0.4))
    horizon = 6
    size = SolveSize("solve_game", horizon, 64, 4, grid.size, grid.budget_levels, 4 + grid.size, 6)
    tracemalloc.start()
    try:
        solve_game(family, grid, horizon)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert size.bytes / 2 <= peak <= size.bytes


def test_grid_builders_refuse_a_grid_too_fine_to_measure_before_building_it():
    """slip_line_grid(θ, 1e-4) spent minutes measuring 10^8 moves without a word."""
    started = time.monotonic()
    with pytest.raises(ValueError, match=r"10,001 points, beyond max_points=1000.*13 min"):
        slip_line_grid(theta(0.5), 1e-4)
    assert time.monotonic() - started < 1.0
    with pytest.raises(ValueError, match="3 points, beyond max_points=2"):
        nature_grid([theta(0.2), theta(0.4)], theta(0.5), max_points=2)
    assert slip_line_grid(theta(0.5), 0.25, max_points=5).size == 5
    with pytest.raises(TypeError, match="max_points=2.5 must be an int"):
        slip_line_grid(theta(0.5), 0.25, max_points=2.5)  # type: ignore[arg-type]


def test_progress_is_opt_in_and_goes_to_stderr(capsys):
    """Quiet by default; with progress=True the size, then the steps done."""
    family, grid, horizon = small()
    solve_game(family, grid, horizon)
    assert capsys.readouterr() == ("", "")
    game = solve_game(family, grid, horizon, progress=True)
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert out == "" and lines[0].startswith("solve_game: 16 states × 11 θ × 4 budget levels × 5")
    assert lines[-1].startswith("solve_game: step 5/5, ")
    stale = stale_policy(family, theta(0.7), horizon)
    exploitability(family, stale, grid, horizon, game=game, progress=True)
    assert capsys.readouterr().err.splitlines()[-1].startswith("nature_best_response: step 5/5")
    with pytest.raises(TypeError, match="progress='yes' must be a bool"):
        solve_game(family, grid, horizon, progress="yes")  # type: ignore[arg-type]
