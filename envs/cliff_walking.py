"""CliffWalking whose slipperiness is θ.

Gymnasium's ``CliffWalking-v1`` grid (4 x 12, start (3, 0), goal (3, 11), the cliff between
them). θ is the slip vector ``[intended, action+1, action-1, reverse]`` (NS-Gym's convention):
the move made is the intended one, a perpendicular one, or the opposite one. Actions: 0 UP,
1 RIGHT, 2 DOWN, 3 LEFT. Every move onto a free cell costs -1; stepping into the cliff costs
-100 and sends the agent back to the start without ending the episode, as in Gymnasium; entering
the goal pays ``goal_reward`` (Gymnasium: -1; the NS-Gym paper: +100) and ends the episode.
``slip = (1, 0, 0, 0)`` (the default) is Gymnasium's deterministic CliffWalking.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ns_pz.envs.grid import Outcome, SlipGridFamily

from ns_pz.nature.updates import check_real
from ns_pz.params import Params, simplex

DESC = ("FFFFFFFFFFFF", "FFFFFFFFFFFF", "FFFFFFFFFFFF", "SCCCCCCCCCCG")
MOVES = ((-1, 0), (0, 1), (1, 0), (0, -1))  # UP, RIGHT, DOWN, LEFT as (d_row, d_col)


@dataclass(frozen=True, slots=True)
class CliffWalkingParams(Params):
    """Slip probabilities of CliffWalking (default: deterministic, as Gymnasium's)."""

    slip: tuple[float, ...] = simplex(
        (1.0, 0.0, 0.0, 0.0),
        outcomes=("intended", "action+1", "action-1", "reverse"),
        doc="probability of moving as intended, turned by +1 / -1 action index, or reversed",
    )


class CliffWalkingFamily(SlipGridFamily):
    """CliffWalking dynamics under :class:`CliffWalkingParams`.

    Args:
        goal_reward: Reward for entering the goal (Gymnasium: -1.0; the NS-Gym paper: 100.0;
            NS-Gym's wrapper: 0.0).
        cliff_reward: Reward for stepping into the cliff (Gymnasium: -100.0).
        step_reward: Reward for entering any other cell (Gymnasium: -1.0).
        terminal_cliff: Whether stepping into the cliff also ends the episode (the agent is
            still put back on the start cell; NS-Gym's ``terminal_cliff``).
    """

    params_cls = CliffWalkingParams

    def __init__(
        self,
        goal_reward: float = -1.0,
        cliff_reward: float = -100.0,
        step_reward: float = -1.0,
        terminal_cliff: bool = False,
    ) -> None:
        self.goal_reward = check_real("goal_reward", goal_reward)
        self.cliff_reward = check_real("cliff_reward", cliff_reward)
        self.step_reward = check_real("step_reward", step_reward)
        if not isinstance(terminal_cliff, bool):
            raise TypeError(f"terminal_cliff={terminal_cliff!r} must be a bool")
        self.terminal_cliff = terminal_cliff
        super().__init__(DESC, MOVES, offsets=(0, 1, -1, 2))

    def cell_outcome(self, state: int, row: int, col: int) -> Outcome:
        """The cliff costs ``cliff_reward`` and restarts; the goal pays ``goal_reward`` and ends."""
        letter = self.desc[row][col]
        if letter == "C":
            return self.start_states[0], self.cliff_reward, self.terminal_cliff
        if letter == "G":
            return row * self.ncol + col, self.goal_reward, True
        return row * self.ncol + col, self.step_reward, False

    def is_terminal_state(self, state: int) -> bool:
        """Only the goal ends an episode (the cliff cells are never occupied)."""
        return self.cell(state) == "G"

    def slip_param_of(self, state: int) -> str:
        """One global slip vector."""
        return "slip"

    def check_state(self, state: Any) -> int:
        """A cell index in ``[0, 48)`` that is not a cliff cell (the agent never stands there).

        Raises:
            ValueError: It is not an integer, is out of range, or is a cliff cell.
        """
        index = super().check_state(state)
        if self.cell(index) == "C":
            cliff = [s for s in range(self.nrow * self.ncol) if self.cell(s) == "C"]
            raise ValueError(
                f"state={state!r} is a cliff cell of {self!r}, where the agent never stands; "
                f"allowed: an int in [0, {self.nrow * self.ncol}) other than {cliff}"
            )
        return index

    def __repr__(self) -> str:
        return (
            f"CliffWalkingFamily(goal_reward={self.goal_reward!r}, "
            f"cliff_reward={self.cliff_reward!r}, step_reward={self.step_reward!r}, "
            f"terminal_cliff={self.terminal_cliff!r})"
        )
