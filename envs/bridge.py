"""The Bridge of Lecarpentier & Rachelson (2019), as NS-Gym's benchmark uses it.

A 5 x 8 grid: start (2, 4); goals (+1, terminal) at (2, 0), four moves away along a safe road,
and at (2, 7), three moves away across a narrow bridge between holes; holes (-1, terminal) all
around. Actions 0 LEFT, 1 DOWN, 2 RIGHT, 3 UP; a move slips to a perpendicular one as in
FrozenLake, with θ's slip vector ``[intended, action+1, action-1]``.

:class:`BridgeFamily` has one global slip vector (the paper's setting). :class:`SplitBridgeFamily`
has one for the left half (columns 0-3) and one for the right half (columns 4-7), chosen by the
cell the agent is in. ``map_name="extra_hole"`` is NS-Gym's later map, with a hole at (2, 2)
that cuts the safe road.
"""

from __future__ import annotations

from dataclasses import dataclass

from ns_pz.envs.grid import GoalHoleGridFamily

from ns_pz.params import Params, simplex

MAPS = {
    "paper": ("HHHHHHHH", "FFFFFHHH", "GFFFSFFG", "FFFFFHHH", "HHHHHHHH"),
    "extra_hole": ("HHHHHHHH", "FFFFFHHH", "GFHFSFFG", "FFFFFHHH", "HHHHHHHH"),
}
MOVES = ((0, -1), (1, 0), (0, 1), (-1, 0))  # LEFT, DOWN, RIGHT, UP as (d_row, d_col)
OUTCOMES = ("intended", "action+1", "action-1")
LEFT_COLUMNS = 4


@dataclass(frozen=True, slots=True)
class BridgeParams(Params):
    """One slip vector for the whole map (default: deterministic)."""

    slip: tuple[float, ...] = simplex(
        (1.0, 0.0, 0.0), outcomes=OUTCOMES, doc="slip probabilities on every cell"
    )


@dataclass(frozen=True, slots=True)
class SplitBridgeParams(Params):
    """One slip vector per half of the map (default: deterministic)."""

    slip_left: tuple[float, ...] = simplex(
        (1.0, 0.0, 0.0), outcomes=OUTCOMES, doc="slip probabilities on columns 0-3"
    )
    slip_right: tuple[float, ...] = simplex(
        (1.0, 0.0, 0.0), outcomes=OUTCOMES, doc="slip probabilities on columns 4-7"
    )


class BridgeFamily(GoalHoleGridFamily):
    """Bridge dynamics with one global slip vector.

    Args:
        map_name: ``"paper"`` (Lecarpentier's map, used by the NS-Gym paper) or
            ``"extra_hole"`` (NS-Gym's later map).
    """

    params_cls: type[Params] = BridgeParams

    def __init__(self, map_name: str = "paper") -> None:
        if map_name not in MAPS:
            raise ValueError(f"map_name={map_name!r} is not a map; allowed: {sorted(MAPS)}")
        self.map_name = map_name
        rewards = {"G": 1.0, "H": -1.0, "F": 0.0}
        super().__init__(MAPS[map_name], MOVES, offsets=(0, 1, -1), rewards=rewards)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(map_name={self.map_name!r})"


class SplitBridgeFamily(BridgeFamily):
    """Bridge dynamics with a slip vector per half, chosen by the agent's current column."""

    params_cls = SplitBridgeParams

    def slip_param_of(self, state: int) -> str:
        """``slip_left`` on columns 0-3, ``slip_right`` on columns 4-7."""
        return "slip_left" if state % self.ncol < LEFT_COLUMNS else "slip_right"
