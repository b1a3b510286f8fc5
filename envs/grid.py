"""Grid worlds whose moves slip according to θ: the common base of the tabular families.

The agent picks one of four directions; the move actually made is ``(action + offsets[k]) % 4``
with probability ``θ[k]``, where θ is a probability vector (a "slip vector"). Moving off the grid
leaves the agent in place. What a cell does (reward, terminal, teleport) is up to the family.

All outcomes are computed once per map: ``outcome k`` of action ``a`` in state ``s`` is a fixed
(next state, reward, terminal) triple, and only its probability follows θ. A change of θ is
therefore free: no table is rebuilt, in Python or otherwise. Each outcome also has its *landing
cell*, the cell its move enters before the family's rule applies (CliffWalking's cliff cells send
the agent on to the start): the table's ``landing_cells``, what a ground metric between outcomes
is measured on.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from ns_pz.family import EnvFamily
from ns_pz.params import Params
from ns_pz.planning import TabularModel, TabularOutcomes
from ns_pz.states import check_index_state

if TYPE_CHECKING:
    from ns_pz.envs.rendering import GridPainter

Outcome = tuple[int, float, bool]


class SlipGridFamily(EnvFamily):
    """A slippery grid world on a character map.

    Args:
        desc: The map, one string per row, all of one length.
        moves: ``(d_row, d_col)`` of each action, in action order.
        offsets: Action offset of each slip outcome, in the order of θ's slip vector.
        start_cells: Characters marking start cells (the start is uniform over them).
    """

    def __init__(
        self,
        desc: Sequence[str],
        moves: Sequence[tuple[int, int]],
        offsets: Sequence[int],
        start_cells: str = "S",
    ) -> None:
        self.desc = check_map(desc)
        self.nrow = len(self.desc)
        self.ncol = len(self.desc[0])
        self.moves = tuple(moves)
        self.offsets = tuple(offsets)
        num_states = self.nrow * self.ncol
        self.observation_space = spaces.Discrete(num_states)
        self.action_space = spaces.Discrete(len(self.moves))
        self.start_states = tuple(s for s in range(num_states) if self.cell(s) in start_cells)
        if not self.start_states:
            raise ValueError(f"desc={list(desc)!r} has no start cell ({start_cells!r})")
        self._start_probs = (1.0 / len(self.start_states),) * len(self.start_states)
        self._table = tuple(
            tuple(self._outcomes_of(s, a) for a in range(len(self.moves)))
            for s in range(num_states)
        )
        self._slip_param = tuple(self.slip_param_of(s) for s in range(num_states))
        self._structure = _structure_arrays(self._table)
        self._landing_cells = _read_only(
            np.array(
                [
                    [self._landing_cells_of(s, a) for a in range(len(self.moves))]
                    for s in range(num_states)
                ],
                dtype=np.int64,
            )
        )

    # -- what a family defines --------------------------------------------------------------
    @abstractmethod
    def cell_outcome(self, state: int, row: int, col: int) -> Outcome:
        """Entering cell (row, col) from ``state``: (next state, reward, terminal)."""

    @abstractmethod
    def is_terminal_state(self, state: int) -> bool:
        """Whether an episode has ended once the agent is in ``state``."""

    @abstractmethod
    def slip_param_of(self, state: int) -> str:
        """Name of the θ field holding the slip vector that applies in ``state``."""

    # -- shared machinery -------------------------------------------------------------------
    def cell(self, state: int) -> str:
        """The map character of ``state``."""
        return self.desc[state // self.ncol][state % self.ncol]

    def _outcomes_of(self, state: int, action: int) -> tuple[Outcome, ...]:
        if self.is_terminal_state(state):
            return tuple((state, 0.0, True) for _ in self.offsets)
        return tuple(
            self.cell_outcome(state, *divmod(cell, self.ncol))
            for cell in self._landing_cells_of(state, action)
        )

    def _landing_cells_of(self, state: int, action: int) -> tuple[int, ...]:
        """The cell each slip outcome's move enters (off the grid: stays; terminal: ``state``)."""
        if self.is_terminal_state(state):
            return (state,) * len(self.offsets)
        row, col = divmod(state, self.ncol)
        cells = []
        for offset in self.offsets:
            d_row, d_col = self.moves[(action + offset) % len(self.moves)]
            new_row = min(max(row + d_row, 0), self.nrow - 1)
            new_col = min(max(col + d_col, 0), self.ncol - 1)
            cells.append(new_row * self.ncol + new_col)
        return tuple(cells)

    def initial_state(self, rng: np.random.Generator) -> int:
        """A start cell, uniformly (one uniform draw, as Gymnasium's toy-text envs)."""
        return self.start_states[_pick(self._start_probs, rng.random())]

    def step(
        self,
        state: int,
        action: int,
        theta: Params,
        rng: np.random.Generator,  # type: ignore[override]
    ) -> Outcome:
        """Sample one slip outcome with θ's probabilities (one uniform draw)."""
        probs = getattr(theta, self._slip_param[state])
        u = rng.random()
        total = 0.0
        for k, p in enumerate(probs):
            total += p
            if u < total:
                return self._table[state][action][k]
        return self._table[state][action][_pick(probs, u)]

    render_modes = ("human", "rgb_array", "ansi")
    render_fps = 4

    def painter(self) -> GridPainter:
        """The map and the agent, drawn with NumPy (see :mod:`ns_pz.envs.rendering`)."""
        from ns_pz.envs.rendering import GridPainter

        return GridPainter(self)

    def observe(self, state: int) -> int:
        """The state index ``row * ncol + col``."""
        return state

    def check_state(self, state: Any) -> int:
        """``state`` as an ``int`` cell index in ``[0, nrow * ncol)``.

        Raises:
            ValueError: It is not an integer (``bool`` included) or is out of range.
        """
        return check_index_state(self, state, self.nrow * self.ncol)

    def outcomes(self, theta: Params) -> TabularOutcomes:
        """The explicit table under ``theta``; the structure arrays are shared, not copied."""
        names = sorted(set(self._slip_param))
        vectors = np.array([getattr(theta, name) for name in names], dtype=np.float64)
        index = np.array([names.index(name) for name in self._slip_param])
        num_states, num_actions, num_outcomes = self._structure[0].shape
        probs = np.broadcast_to(vectors[index][:, None, :], (num_states, num_actions, num_outcomes))
        next_states, rewards, terminals = self._structure
        return TabularOutcomes(probs, next_states, rewards, terminals, self._landing_cells)

    def planning_model(self, theta: Params, state: int, rng: np.random.Generator) -> TabularModel:
        """A stationary model with the explicit outcome table."""
        return TabularModel(self, theta, state, rng)


class GoalHoleGridFamily(SlipGridFamily):
    """A slip grid on a map of S (start), F (free), H (hole) and G (goal) cells.

    Entering a goal or a hole ends the episode; entering any cell pays ``rewards[letter]``
    (``rewards["F"]`` for the start cell too). One global slip vector, θ's ``slip`` field, unless
    a subclass overrides :meth:`slip_param_of`.

    Args:
        desc: The map.
        moves: ``(d_row, d_col)`` of each action.
        offsets: Action offset of each slip outcome.
        rewards: Reward for entering a cell of each letter ``"G"``, ``"H"`` and ``"F"``.
    """

    def __init__(
        self,
        desc: Sequence[str],
        moves: Sequence[tuple[int, int]],
        offsets: Sequence[int],
        rewards: dict[str, float],
    ) -> None:
        bad = {c for row in desc for c in row} - set("SFHG")
        if bad:
            raise ValueError(f"desc has unknown cells {sorted(bad)}; allowed: S, F, H, G")
        self.cell_rewards = {**rewards, "S": rewards["F"]}
        super().__init__(desc, moves, offsets)

    def cell_outcome(self, state: int, row: int, col: int) -> Outcome:
        """Goals and holes end the episode; every cell pays its letter's reward."""
        letter = self.desc[row][col]
        return row * self.ncol + col, self.cell_rewards[letter], letter in "GH"

    def is_terminal_state(self, state: int) -> bool:
        """Goal and hole cells."""
        return self.cell(state) in "GH"

    def slip_param_of(self, state: int) -> str:
        """One global slip vector."""
        return "slip"


def _pick(probs: Sequence[float], u: float) -> int:
    """Index of the first cumulative probability above ``u``.

    If rounding leaves the sum a hair below ``u``, the last outcome with positive probability is
    taken, never one of probability zero.
    """
    total = 0.0
    for k, p in enumerate(probs):
        total += p
        if u < total:
            return k
    return max(k for k, p in enumerate(probs) if p > 0.0)


def _structure_arrays(table: Sequence[Sequence[Sequence[Outcome]]]) -> tuple[np.ndarray, ...]:
    next_states = np.array([[[o[0] for o in row] for row in by_s] for by_s in table], np.int64)
    rewards = np.array([[[o[1] for o in row] for row in by_s] for by_s in table], np.float64)
    terminals = np.array([[[o[2] for o in row] for row in by_s] for by_s in table], np.bool_)
    return _read_only(next_states), _read_only(rewards), _read_only(terminals)


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def check_map(desc: Sequence[str]) -> tuple[str, ...]:
    """Validate a character map: a non-empty list of equally long, non-empty strings.

    Raises:
        TypeError: ``desc`` is not a sequence of strings.
        ValueError: rows are empty or of different lengths.
    """
    if isinstance(desc, (str, bytes)) or not isinstance(desc, Sequence):
        raise TypeError(f"desc={desc!r} must be a list of strings, one per row")
    rows = tuple(row.decode() if isinstance(row, bytes) else row for row in desc)
    if not rows or not all(isinstance(row, str) and row for row in rows):
        raise ValueError(f"desc={list(desc)!r} must be a non-empty list of non-empty strings")
    if len({len(row) for row in rows}) != 1:
        raise ValueError(f"desc={list(desc)!r} has rows of different lengths")
    return rows
