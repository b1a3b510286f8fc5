"""The NS-MDP game on a nature grid as an OpenSpiel game, for the levels where the agent is blind.

At ``none`` / ``basic`` the agent does not see θ, so one agent information set joins histories
with different θ: Shapley's stage-by-stage induction does not apply. OpenSpiel's algorithms for
imperfect-information games do: :class:`NSMDPGame` is the game as an extensive form (player 0
the agent, player 1 nature, chance the transitions), and :func:`cfr_value_bracket` runs CFR+ on
it and brackets the value with two best responses:

    V(π̄, BR(π̄)) <= value <= V(BR(ν̄), ν̄)

where ``π̄, ν̄`` are CFR's average strategies (the gap is OpenSpiel's NashConv and shrinks as
CFR runs). Each step is played as nature's move, then the agent's, then chance's; the agent's
information state does not include nature's move at this step, which makes the two moves
simultaneous as in ns_pz's game. The agent's information state is its own history of
states and actions, plus at ``basic`` whether θ changed behind each past transition and at
``detailed`` θ_{t-1} itself (nature's past grid indices). Nature's is its own past moves and, by
default, the agent's states.

The tree grows as ``(moves · actions · outcomes)^H``: this is for small instances (a few steps
on a small map). Needs the ``openspiel`` extra (``pip install open-spiel``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

try:
    import pyspiel
except ImportError as error:  # the optional extra: say how to get it
    raise ImportError(
        f"ns_pz.agents.exact.openspiel_game needs OpenSpiel ({error}): "
        "pip install 'ns_pz[openspiel]'"
    ) from None
from ns_pz.agents.exact.game_stages import check_game, family_of, grid_tables
from ns_pz.agents.exact.nature_grid import NatureGrid

AGENT, NATURE = 0, 1
LEVELS = ("none", "basic", "detailed")


class NSMDPGame(pyspiel.Game):
    """A tabular NS-MDP with nature on a finite grid, as a two-player zero-sum OpenSpiel game.

    Args:
        env: A tabular family, or an env built on one.
        grid: Nature's action set.
        horizon: ``H`` (number of transitions).
        level: What the agent is told: ``"none"``, ``"basic"`` or ``"detailed"``.
        nature_sees_state: Whether nature's information includes the agent's states.

    Raises:
        ValueError: An unknown level (and the errors of the exact solvers for the rest).
    """

    def __init__(
        self,
        env: Any,
        grid: NatureGrid,
        horizon: int,
        *,
        level: str = "none",
        nature_sees_state: bool = True,
    ) -> None:
        if level not in LEVELS:
            raise ValueError(f"level={level!r} is not a notification level; allowed: {LEVELS}")
        self.horizon = check_game(horizon, 1.0)[0]
        self.family = family_of(env)
        self.grid = grid
        self.tables = grid_tables(env, grid)
        self.level = level
        self.nature_sees_state = nature_sees_state
        self.next_budget = grid.next_budget()
        num_states, num_actions, num_outcomes = self.tables[0].probs.shape
        self.num_actions = num_actions
        rewards = np.abs(np.stack([t.rewards for t in self.tables]))
        bound = float(rewards.max()) * self.horizon
        game_type = pyspiel.GameType(
            short_name="python_ns_pz_grid_game",
            long_name="ns_pz NS-MDP on a nature grid",
            dynamics=pyspiel.GameType.Dynamics.SEQUENTIAL,
            chance_mode=pyspiel.GameType.ChanceMode.EXPLICIT_STOCHASTIC,
            information=pyspiel.GameType.Information.IMPERFECT_INFORMATION,
            utility=pyspiel.GameType.Utility.ZERO_SUM,
            reward_model=pyspiel.GameType.RewardModel.TERMINAL,
            max_num_players=2,
            min_num_players=2,
            provides_information_state_string=True,
            provides_information_state_tensor=False,
            provides_observation_string=False,
            provides_observation_tensor=False,
        )
        game_info = pyspiel.GameInfo(
            num_distinct_actions=max(num_actions, grid.size),
            max_chance_outcomes=max(num_outcomes, len(self.family.start_states)),
            num_players=2,
            min_utility=-bound,
            max_utility=bound,
            utility_sum=0.0,
            max_game_length=3 * self.horizon + 1,
        )
        super().__init__(game_type, game_info, {})

    def new_initial_state(self) -> NSMDPState:
        """The state before the start state is drawn."""
        return NSMDPState(self)

    def make_py_observer(self, iig_obs_type: Any = None, params: Any = None) -> InfoStateObserver:
        """The information-state observer (strings only)."""
        return InfoStateObserver()


class NSMDPState(pyspiel.State):
    """A history of the game: states, nature's grid indices, actions, return so far."""

    def __init__(self, game: NSMDPGame) -> None:
        super().__init__(game)
        self.game = game
        self.states: list[int] = []
        self.choices: list[int] = []
        self.actions: list[int] = []
        self.budget = game.grid.full_budget
        self.total = 0.0
        self.over = False

    def clone(self) -> NSMDPState:
        """A copy, rebuilt by replaying the history (so OpenSpiel's history is kept too).

        OpenSpiel's default copy looks the game up by name in its registry, where a game built
        from Python objects (a family, a grid) cannot be.
        """
        state = NSMDPState(self.game)
        for action in self.history():
            state.apply_action(action)
        return state

    def __deepcopy__(self, memo: dict[int, Any]) -> NSMDPState:
        return self.clone()

    def child(self, action: int) -> NSMDPState:
        """The state after ``action``."""
        state = self.clone()
        state.apply_action(action)
        return state

    def _here(self) -> int:
        return self.choices[-1] if self.choices else self.game.grid.start

    def current_player(self) -> int:
        """Chance at the start and after each action; nature, then the agent, each step."""
        if self.over:
            return pyspiel.PlayerId.TERMINAL
        if not self.states or len(self.actions) == len(self.states):
            return pyspiel.PlayerId.CHANCE
        return NATURE if len(self.choices) < len(self.states) else AGENT

    def _legal_actions(self, player: int) -> list[int]:
        if player == AGENT:
            return list(range(self.game.num_actions))
        return [
            int(j) for j in np.flatnonzero(self.game.next_budget[self._here(), self.budget] >= 0)
        ]

    def chance_outcomes(self) -> list[tuple[int, float]]:
        """The start state, or the outcomes of the last (state, action) under θ_t."""
        if not self.states:
            starts = self.game.family.start_states
            return [(k, 1.0 / len(starts)) for k in range(len(starts))]
        probs = self.game.tables[self.choices[-1]].probs[self.states[-1], self.actions[-1]]
        return [(int(k), float(p)) for k, p in enumerate(probs) if p > 0.0]

    def _apply_action(self, action: int) -> None:
        game = self.game
        if not self.states:
            self.states.append(int(game.family.start_states[action]))
        elif self.current_player() == NATURE:
            self.budget = int(game.next_budget[self._here(), self.budget, action])
            self.choices.append(int(action))
        elif self.current_player() == AGENT:
            self.actions.append(int(action))
        else:
            table = game.tables[self.choices[-1]]
            s, a = self.states[-1], self.actions[-1]
            self.total += float(table.rewards[s, a, action])
            self.states.append(int(table.next_states[s, a, action]))
            self.over = bool(table.terminals[s, a, action]) or len(self.actions) == game.horizon

    def _action_to_string(self, player: int, action: int) -> str:
        if player == NATURE:
            return f"theta{action}"
        if player == AGENT:
            return f"a{action}"
        return f"outcome{action}"

    def is_terminal(self) -> bool:
        """Whether the episode ended (terminal outcome or horizon)."""
        return self.over

    def returns(self) -> list[float]:
        """The agent's return so far and its negative for nature."""
        return [self.total, -self.total]

    def information_state_string(self, player: int | None = None) -> str:
        """What ``player`` knows (module docstring)."""
        if player is None:
            player = self.current_player()
        return self.game_info_string(player)

    def game_info_string(self, player: int) -> str:
        """The information state of ``player`` as a string."""
        states = ",".join(map(str, self.states))
        if player == NATURE:
            seen = states if self.game.nature_sees_state else f"t{len(self.choices)}"
            return f"N|{seen}|{','.join(map(str, self.choices))}"
        known = self.choices[: len(self.actions)]  # θ_0 .. θ_{t-1}, not θ_t
        told = ""
        if self.game.level == "detailed":
            told = ",".join(map(str, known))
        elif self.game.level == "basic":
            before = [self.game.grid.start, *known][: len(known)]
            told = "".join("1" if j != i else "0" for i, j in zip(before, known, strict=True))
        return f"A|{states}|{','.join(map(str, self.actions))}|{told}"

    def __str__(self) -> str:
        return f"s={self.states} theta={self.choices} a={self.actions} R={self.total}"


class InfoStateObserver:
    """Information-state strings for OpenSpiel's observation API (no tensors)."""

    def __init__(self) -> None:
        self.tensor = np.zeros(0, np.float32)
        self.dict: dict[str, np.ndarray] = {}

    def set_from(self, state: NSMDPState, player: int) -> None:
        """No tensor to fill."""

    def string_from(self, state: NSMDPState, player: int) -> str:
        """The player's information state."""
        return state.game_info_string(player)


@dataclass(frozen=True)
class ValueBracket:
    """Bounds on the game's value from CFR's average strategies.

    Attributes:
        lower: The agent's average strategy against nature's best response.
        upper: The agent's best response against nature's average strategy.
        iterations: CFR+ iterations run.
        info_states: Information states of both players.
    """

    lower: float
    upper: float
    iterations: int
    info_states: int

    @property
    def gap(self) -> float:
        """``upper - lower`` (OpenSpiel's NashConv)."""
        return self.upper - self.lower


def cfr_value_bracket(game: NSMDPGame, iterations: int = 200) -> ValueBracket:
    """Run CFR+ and bracket the value with best responses to its average strategies.

    Raises:
        ValueError: ``iterations < 1``.
    """
    from open_spiel.python.algorithms import cfr, exploitability

    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations={iterations!r} must be an int >= 1")
    solver = cfr.CFRPlusSolver(game)
    for _ in range(iterations):
        solver.evaluate_and_update_policy()
    average = solver.average_policy()
    against_nature = exploitability.best_response(game, average, AGENT)
    against_agent = exploitability.best_response(game, average, NATURE)
    return ValueBracket(
        lower=-float(against_agent["best_response_value"]),
        upper=float(against_nature["best_response_value"]),
        iterations=iterations,
        info_states=len(average.state_lookup),
    )
