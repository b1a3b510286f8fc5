"""The blind-agent game through OpenSpiel (runs where ``open-spiel`` installs)."""

from __future__ import annotations

import pytest

pytest.importorskip("pyspiel")

from ns_pz.agents.exact import equal_split, nature_grid, solve_game  # noqa: E402
from ns_pz.agents.exact.openspiel_game import NSMDPGame, cfr_value_bracket  # noqa: E402
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams  # noqa: E402


def tiny():
    """A 2x2 lake, nature between p = 0.2 and 0.9 (from 0.9), two steps."""
    family = FrozenLakeFamily(desc=("SF", "HG"))
    points = [FrozenLakeParams(slip=equal_split(p, 3)) for p in (0.2, 0.9)]
    return family, nature_grid(points, points[1]), 2


def test_cfr_bracket_holds_the_exact_value_at_detailed_and_is_below_it_at_none():
    """At detailed CFR brackets Shapley's value; blind, the value can only be lower."""
    family, grid, horizon = tiny()
    exact = solve_game(family, grid, horizon).value
    detailed = cfr_value_bracket(NSMDPGame(family, grid, horizon, level="detailed"), 60)
    assert detailed.lower - 1e-9 <= exact <= detailed.upper + 1e-9
    assert detailed.gap < 0.01
    blind = cfr_value_bracket(NSMDPGame(family, grid, horizon, level="none"), 60)
    assert blind.lower <= exact + 1e-9
    assert blind.info_states < detailed.info_states  # the blind agent tells fewer apart


def test_information_states_hide_the_current_theta():
    """The agent's information never includes nature's move of this step."""
    family, grid, horizon = tiny()
    game = NSMDPGame(family, grid, horizon, level="detailed")
    state = game.new_initial_state()
    state.apply_action(0)  # the start state
    low, high = state.child(0), state.child(1)  # nature picks p = 0.2 or 0.9
    assert low.information_state_string(0) == high.information_state_string(0)
    assert low.information_state_string(1) != high.information_state_string(1)
    with pytest.raises(ValueError, match="level='full' is not a notification level"):
        NSMDPGame(family, grid, horizon, level="full")
    with pytest.raises(ValueError, match="iterations=0 must be an int >= 1"):
        cfr_value_bracket(game, 0)
