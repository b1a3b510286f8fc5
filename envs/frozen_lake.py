"""FrozenLake whose slipperiness is θ.

The map, start, goal (+1, terminal) and holes (0, terminal) are Gymnasium's ``FrozenLake-v1``.
θ is the slip vector ``[intended, action+1, action-1]`` (NS-Gym's convention): the move made is
the intended one, or one of the two perpendicular ones. Actions: 0 LEFT, 1 DOWN, 2 RIGHT, 3 UP,
so ``action+1`` turns LEFT into DOWN. Gymnasium's slippery lake is ``slip = (1/3, 1/3, 1/3)``
(listed there in the order action-1, action, action+1); the deterministic lake is ``(1, 0, 0)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ns_pz.envs.grid import GoalHoleGridFamily

from ns_pz.params import Params, simplex

MAPS = {
    "4x4": ("SFFF", "FHFH", "FFFH", "HFFG"),
    "8x8": (
        "SFFFFFFF",
        "FFFFFFFF",
        "FFFHFFFF",
        "FFFFFHFF",
        "FFFHFFFF",
        "FHHFFFHF",
        "FHFFHFHF",
        "FFFHFFFG",
    ),
}

MOVES = ((0, -1), (1, 0), (0, 1), (-1, 0))  # LEFT, DOWN, RIGHT, UP as (d_row, d_col)


@dataclass(frozen=True, slots=True)
class FrozenLakeParams(Params):
    """Slip probabilities of FrozenLake (default: Gymnasium's slippery lake)."""

    slip: tuple[float, ...] = simplex(
        (1 / 3, 1 / 3, 1 / 3),
        outcomes=("intended", "action+1", "action-1"),
        doc="probability of moving as intended, or turned by +1 / -1 action index",
    )


class FrozenLakeFamily(GoalHoleGridFamily):
    """FrozenLake dynamics under :class:`FrozenLakeParams`.

    Args:
        map_name: ``"4x4"`` or ``"8x8"``, used when ``desc`` is not given.
        desc: A custom map of ``S`` (start), ``F`` (frozen), ``H`` (hole), ``G`` (goal).
        reward_schedule: Rewards for entering (goal, hole, frozen), as Gymnasium's.
    """

    params_cls = FrozenLakeParams

    def __init__(
        self,
        map_name: str = "4x4",
        desc: Sequence[str] | None = None,
        reward_schedule: tuple[float, float, float] = (1.0, 0.0, 0.0),
    ) -> None:
        if desc is None:
            if map_name not in MAPS:
                raise ValueError(f"map_name={map_name!r} is not a map; allowed: {sorted(MAPS)}")
            desc = MAPS[map_name]
        self.map_name = map_name
        if len(reward_schedule) != 3:
            raise ValueError(
                f"reward_schedule={reward_schedule!r} must be (goal, hole, frozen) rewards"
            )
        self.reward_schedule = tuple(float(r) for r in reward_schedule)
        goal, hole, frozen = self.reward_schedule
        rewards = {"G": goal, "H": hole, "F": frozen}
        super().__init__(desc, MOVES, offsets=(0, 1, -1), rewards=rewards)

    def __repr__(self) -> str:
        """Every argument that changes the dynamics (caches and detectors key on it).

        The default reward schedule is left out, so existing cache keys stay valid.
        """
        schedule = self.reward_schedule
        rewards = "" if schedule == (1.0, 0.0, 0.0) else f", reward_schedule={schedule!r}"
        return f"FrozenLakeFamily(desc={list(self.desc)!r}{rewards})"
