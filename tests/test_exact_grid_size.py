"""The slip-line grid refuses a step that would make it too large, naming its size."""

from __future__ import annotations

import time

import pytest
from ns_pz.agents.exact.nature_grid import MAX_LINE_POINTS, slip_line_grid
from ns_pz.envs.frozen_lake import FrozenLakeParams


def test_a_slip_line_grid_too_fine_is_refused_with_its_size() -> None:
    """slip_line_grid(θ, 1e-4) compared 10**8 pairs of points without a word."""
    theta = FrozenLakeParams(slip=(0.9, 0.05, 0.05))
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"step=0.0001 puts 10001 points .* 100020001 pairs"):
        slip_line_grid(theta, 1e-4)
    assert time.perf_counter() - start < 1.0
    with pytest.raises(ValueError, match=rf"at most {MAX_LINE_POINTS} points: step >= 0.0005"):
        slip_line_grid(theta, 1e-4)
    assert len(slip_line_grid(theta, 0.05, low=0.5).thetas) == 11  # ordinary steps still build
