"""The blind-agent game through OpenSpiel (runs where ``open-spiel`` installs)."""

from __future__ import annotations

import pytest

pytest.importorskip("pyspiel")

from ns_pz.agents.exact import equal_split, nature_grid, solve_game  # noqa: E402
from ns_pz.agents.exact.game_stages import grid_tables  # noqa: E402
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


def test_nature_sees_the_agents_past_actions_as_the_environments_nature_does():
    """The environment's state-observing nature sees a_{t-1}; the export's did not."""
    family, grid, horizon = tiny()
    table = grid_tables(family, grid)[1]

    def after(game, action):
        """Start in 0, nature stays, the agent plays ``action``, and lands back in 0."""
        state = game.new_initial_state()
        state.apply_action(0)
        state.apply_action(1)
        state.apply_action(action)
        outcome = next(
            k
            for k, p in enumerate(table.probs[0, action])
            if p > 0 and table.next_states[0, action, k] == 0
        )
        state.apply_action(outcome)
        return state

    seeing = NSMDPGame(family, grid, horizon, level="none")
    left, up = after(seeing, 0), after(seeing, 3)
    assert left.current_player() == up.current_player() == 1  # nature's turn at t = 1
    assert left.information_state_string(1) != up.information_state_string(1)
    assert left.information_state_string(0) != up.information_state_string(0)  # perfect recall
    blind = NSMDPGame(family, grid, horizon, level="none", nature_sees_state=False)
    assert after(blind, 0).information_state_string(1) == after(blind, 3).information_state_string(
        1
    )


def test_a_game_too_large_for_cfr_is_refused_with_its_size_and_progress_is_opt_in(capsys):
    """The tree grows as (moves · actions · outcomes)^H: bounded up front."""
    family, grid, _ = tiny()
    with pytest.raises(ValueError, match=r"up to 4.59e\+09 histories .* max_histories=1,000,000"):
        NSMDPGame(family, grid, 7)
    game = NSMDPGame(family, grid, 1, max_histories=24)
    assert game.histories == 24  # 1 start × (2 moves × 4 actions × 3 outcomes)^1
    cfr_value_bracket(game, 2)
    assert capsys.readouterr().err == ""
    cfr_value_bracket(game, 2, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "cfr_value_bracket: up to 24 histories a pass"
    assert lines[-1].startswith("cfr_value_bracket: step 2/2, ")
