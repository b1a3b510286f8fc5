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
simultaneous as in the game (nature moves before it sees a_t). The agent's information
state is its own history of states and actions, plus at ``basic`` whether θ changed behind
each past transition and at ``detailed`` θ_{t-1} itself (nature's past grid indices).

**Nature sees what the environment's state-observing nature sees.** In the environment such a
nature (``NatureInterface(observes_state=True)``, a learned or a :class:`PolicyNature`) observes
at step ``t`` the agent's state ``s_t`` *and its last action* ``a_{t-1}``, besides ``t``, θ and
its budget. With perfect recall its information state here is therefore the agent's states
``s_0 .. s_t``, the agent's actions ``a_0 .. a_{t-1}`` and its own past moves
(``nature_sees_state=True``, the default). An earlier version left the actions out: a weaker
nature, and a higher value at ``none`` than the environment's nature concedes. With
``nature_sees_state=False`` nature sees only ``t`` and its own moves (a schedule fixed in
advance in effect, as the environment's nature without ``observes_state``). At ``detailed`` the
state-seeing nature reaches the value of Shapley's induction
(:func:`~ns_pz.agents.exact.game_value.solve_game`), whose nature sees only ``(t, s_t,
θ_{t-1}, budget)``: there the stage is a sufficient statistic, and the past actions cannot help
nature.

The tree grows as ``(moves · actions · outcomes)^H``: this is for small instances (a few steps
on a small map). :class:`NSMDPGame` bounds the number of histories up front and refuses beyond
``max_histories``. Needs the ``openspiel`` extra (``pip install open-spiel``).
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
from ns_pz.agents.exact.solve_progress import SolveProgress

AGENT, NATURE = 0, 1
LEVELS = ("none", "basic", "detailed")
DEFAULT_MAX_HISTORIES = 10**6
"""Most histories :class:`NSMDPGame` accepts by default (CFR visits each every iteration)."""


class NSMDPGame(pyspiel.Game):
    """A tabular NS-MDP with nature on a finite grid, as a two-player zero-sum OpenSpiel game.

    Args:
        env: A tabular family, or an env built on one.
        grid: Nature's action set.
        horizon: ``H`` (number of transitions).
        level: What the agent is told: ``"none"``, ``"basic"`` or ``"detailed"``.
        nature_sees_state: Whether nature's information includes the agent's states and
            actions (module docstring).
        max_histories: Refuse a game whose number of histories may exceed this: the bound
            ``starts · (moves · actions · outcomes)^H``, with the most moves nature has at a
            stage and the most outcomes with probability > 0 of a (state, action).

    Raises:
        ValueError: An unknown level, a game beyond ``max_histories`` (the bound is in the
            message), and the errors of the exact solvers for the rest.
    """

    def __init__(
        self,
        env: Any,
        grid: NatureGrid,
        horizon: int,
        *,
        level: str = "none",
        nature_sees_state: bool = True,
        max_histories: int = DEFAULT_MAX_HISTORIES,
    ) -> None:
        if level not in LEVELS:
            raise ValueError(f"level={level!r} is not a notification level; allowed: {LEVELS}")
        if not isinstance(nature_sees_state, bool):
            raise TypeError(f"nature_sees_state={nature_sees_state!r} must be a bool")
        self.horizon = check_game(horizon, 1.0)[0]
        self.family = family_of(env)
        self.grid = grid
        self.tables = grid_tables(env, grid)
        self.level = level
        self.nature_sees_state = nature_sees_state
        self.next_budget = grid.next_budget()
        self.histories = history_bound(self.family, self.tables, self.next_budget, self.horizon)
        _check_histories(self.histories, max_histories)
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


def history_bound(family: Any, tables: list[Any], next_budget: np.ndarray, horizon: int) -> int:
    """Upper bound on the game's histories: ``starts · (moves · actions · outcomes)^H``."""
    moves = int((next_budget >= 0).sum(axis=2).max())
    num_actions = tables[0].probs.shape[1]
    outcomes = max(int((table.probs > 0).sum(axis=2).max()) for table in tables)
    return len(family.start_states) * (moves * num_actions * outcomes) ** horizon


def _check_histories(histories: int, max_histories: object) -> None:
    if isinstance(max_histories, bool) or not isinstance(max_histories, int):
        raise TypeError(f"max_histories={max_histories!r} must be an int >= 1")
    if max_histories < 1:
        raise ValueError(f"max_histories={max_histories!r} must be >= 1")
    if histories > max_histories:
        raise ValueError(
            f"the game may have up to {histories:.3g} histories (starts × (moves × actions × "
            f"outcomes)^H), beyond max_histories={max_histories:,}: CFR walks every one each "
            "iteration. Shorten the horizon, use fewer grid points or a smaller map, or pass "
            "a larger max_histories"
        )


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
            seen = f"t{len(self.choices)}"
            if self.game.nature_sees_state:  # s_0 .. s_t and a_0 .. a_{t-1}, as in the env
                seen = f"{states}|{','.join(map(str, self.actions))}"
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


def cfr_value_bracket(
    game: NSMDPGame, iterations: int = 200, *, progress: bool = False
) -> ValueBracket:
    """Run CFR+ and bracket the value with best responses to its average strategies.

    Args:
        game: The game.
        iterations: CFR+ iterations.
        progress: Print the game's size bound, then the iterations done and an ETA, on
            stderr.

    Raises:
        ValueError: ``iterations < 1``.
    """
    from open_spiel.python.algorithms import cfr, exploitability

    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations={iterations!r} must be an int >= 1")
    if not isinstance(progress, bool):
        raise TypeError(f"progress={progress!r} must be a bool")
    line = None
    if progress:
        line = SolveProgress(
            "cfr_value_bracket", iterations, f"up to {game.histories:.3g} histories a pass"
        )
    solver = cfr.CFRPlusSolver(game)
    for done in range(1, iterations + 1):
        solver.evaluate_and_update_policy()
        if line is not None:
            line.step(done)
    average = solver.average_policy()
    against_nature = exploitability.best_response(game, average, AGENT)
    against_agent = exploitability.best_response(game, average, NATURE)
    return ValueBracket(
        lower=-float(against_agent["best_response_value"]),
        upper=float(against_nature["best_response_value"]),
        iterations=iterations,
        info_states=len(average.state_lookup),
    )
