"""NS-Gym's own environment, the Bridge (``ns_gym.envs.Bridge``), as a plain Gymnasium env.

Registered with Gymnasium as ``ns_pz_compat/Bridge-v0`` (NS-Gym's is ``ns_gym/Bridge-v0``; the
separate namespace lets both packages be installed together). Unlike NS-Gym's, it draws its
slips from the env's own seeded generator, so ``reset(seed=...)`` reproduces a run and
``gymnasium.utils.env_checker.check_env`` passes, and ``info`` is empty. Its slip vectors
(``P``, or ``P_left`` and ``P_right``, also under their older names ``left_side_prob`` and
``right_side_prob``) are settable attributes, as in NS-Gym, and take effect at the next step;
``get_loc_based_prob((row, col))`` gives the one in force on a cell. The dynamics are ns_pz's
Bridge family under ``theta``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, SupportsFloat

import gymnasium as gym

from ns_pz.compat.tables import Table, transition_table
from ns_pz.envs.bridge import BridgeFamily, SplitBridgeFamily
from ns_pz.nature.updates import check_distribution, check_real
from ns_pz.params import Params

_SLIP_FIELDS = {
    False: {"P": "slip"},
    True: {"P_left": "slip_left", "P_right": "slip_right"},
}
"""NS-Gym's slip attribute names -> θ fields, by ``split_probs``."""

MAP_NAMES = {"bridge": "extra_hole", "extra_hole": "extra_hole", "paper": "paper"}
"""NS-Gym's ``"bridge"`` map is the one with a hole on the safe road (ns_pz's ``extra_hole``)."""


class Bridge(gym.Env[int, int]):
    """The Bridge grid world with a fixed slip vector.

    Args:
        global_init_probs: Slip vector ``[intended, action+1, action-1]`` (both halves in split
            mode).
        map_name: ``"bridge"`` (NS-Gym's map), ``"extra_hole"`` (the same) or ``"paper"``
            (Lecarpentier's original, without the extra hole).
        epsilon: Accepted for NS-Gym compatibility; unused there too.
        split_probs: One slip vector per half of the map (``P_left``, ``P_right``).
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        global_init_probs: Sequence[float] = (1.0, 0.0, 0.0),
        map_name: str = "bridge",
        epsilon: float = 0.5,
        split_probs: bool = False,
    ) -> None:
        if map_name not in MAP_NAMES:
            raise ValueError(f"map_name={map_name!r} is not a map; allowed: {sorted(MAP_NAMES)}")
        if not isinstance(split_probs, bool):
            raise TypeError(f"split_probs={split_probs!r} must be a bool")
        self.epsilon = check_real("epsilon", epsilon)
        probs = check_distribution("global_init_probs", global_init_probs)
        if len(probs) != 3:
            raise ValueError(
                f"global_init_probs={list(global_init_probs)!r} must have 3 elements "
                "[intended, action+1, action-1]"
            )
        self.map_name = map_name
        self.split_probs = split_probs
        family_cls = SplitBridgeFamily if split_probs else BridgeFamily
        self.family = family_cls(map_name=MAP_NAMES[map_name])
        names = self.family.params_cls.names()
        self.theta: Params = self.family.params_cls(**dict.fromkeys(names, probs))
        self.observation_space = self.family.observation_space
        self.action_space = self.family.action_space
        self.s = self.family.start_states[0]

    @property
    def P(self) -> list[float]:  # noqa: N802 - NS-Gym's name
        """The slip vector ``[intended, action+1, action-1]`` (one Bridge without split_probs).

        Setting it validates the vector and changes the dynamics from the next step on.

        Raises:
            AttributeError: Read on a Bridge built with ``split_probs=True`` (use ``P_left``).
        """
        return list(self._slip("P"))

    @P.setter
    def P(self, value: Sequence[float]) -> None:  # noqa: N802
        self._set_slip("P", value)

    @property
    def P_left(self) -> list[float]:  # noqa: N802 - NS-Gym's name
        """The slip vector of the left half (``split_probs=True`` only); settable like ``P``."""
        return list(self._slip("P_left"))

    @P_left.setter
    def P_left(self, value: Sequence[float]) -> None:  # noqa: N802
        self._set_slip("P_left", value)

    @property
    def P_right(self) -> list[float]:  # noqa: N802 - NS-Gym's name
        """The slip vector of the right half (``split_probs=True`` only); settable like ``P``."""
        return list(self._slip("P_right"))

    @P_right.setter
    def P_right(self, value: Sequence[float]) -> None:  # noqa: N802
        self._set_slip("P_right", value)

    @property
    def left_side_prob(self) -> list[float]:
        """NS-Gym's older name of :attr:`P_left` (``split_probs=True`` only); settable like it."""
        return self.P_left

    @left_side_prob.setter
    def left_side_prob(self, value: Sequence[float]) -> None:
        self.P_left = value  # type: ignore[assignment]

    @property
    def right_side_prob(self) -> list[float]:
        """NS-Gym's older name of :attr:`P_right` (``split_probs=True`` only); settable."""
        return self.P_right

    @right_side_prob.setter
    def right_side_prob(self, value: Sequence[float]) -> None:
        self.P_right = value  # type: ignore[assignment]

    def get_loc_based_prob(self, coord: Sequence[int]) -> list[float]:
        """The slip vector in force on the cell ``coord = (row, col)``.

        Split (``split_probs=True``): ``P_left`` on the left half of the map (``col <
        ncol // 2``), ``P_right`` on the right half, as in NS-Gym; otherwise ``P``, the one
        slip vector of the whole map (NS-Gym returns its unused per-half copies there).

        Raises:
            ValueError: ``coord`` is not a ``(row, col)`` pair of integers on the map.
        """
        return slip_at(self.family, self.theta, coord)

    get_loc_basedProb = get_loc_based_prob  # noqa: N815 - NS-Gym's first spelling, kept there

    @property
    def transition_matrix(self) -> Table:
        """NS-Gym's table ``P[s][a] = [(prob, next_state, reward, terminated), ...]`` now."""
        return transition_table(self.family, self.theta)

    def split(self) -> None:
        """Switch to one slip vector per half (``P_left``, ``P_right``), both the current ``P``.

        What NS-Gym's wrapper does to a Bridge when its ``tunable_params`` name a half.
        """
        if self.split_probs:
            return
        slip = self._slip("P")
        family = SplitBridgeFamily(map_name=MAP_NAMES[self.map_name])
        self.theta = family.params_cls(slip_left=slip, slip_right=slip)
        self.family = family
        self.split_probs = True

    def _field(self, name: str) -> str:
        field = _SLIP_FIELDS[self.split_probs].get(name)
        if field is None:
            have = " and ".join(_SLIP_FIELDS[self.split_probs])
            raise AttributeError(
                f"this Bridge was built with split_probs={self.split_probs}; its slip vectors "
                f"are {have}, not {name}"
            )
        return field

    def _slip(self, name: str) -> tuple[float, ...]:
        return getattr(self.theta, self._field(name))  # type: ignore[no-any-return]

    def _set_slip(self, name: str, value: Sequence[float]) -> None:
        field = self._field(name)
        probs = check_distribution(name, value)
        if len(probs) != 3:
            raise ValueError(f"{name}={list(value)!r} must have 3 elements [intended, +1, -1]")
        self.theta = self.theta.replace(**{field: probs})

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[int, dict[str, Any]]:
        """Back to the start cell."""
        super().reset(seed=seed)
        self.s = self.family.initial_state(self.np_random)
        return self.s, {}

    def step(self, action: int) -> tuple[int, SupportsFloat, bool, bool, dict[str, Any]]:
        """One slippery move, drawn from the env's generator."""
        action = self.family.check_action(action)
        self.s, reward, terminated = self.family.step(self.s, action, self.theta, self.np_random)
        return self.s, float(reward), bool(terminated), False, {}


def slip_at(family: BridgeFamily, theta: Params, coord: Sequence[int]) -> list[float]:
    """The slip vector of ``theta`` that moves the agent on the cell ``coord = (row, col)``.

    Raises:
        ValueError: ``coord`` is not a ``(row, col)`` pair of integers on ``family``'s map.
    """
    try:
        row, col = (int(x) for x in coord if float(x) == int(x))
    except (TypeError, ValueError):
        row = col = -1
    if not (0 <= row < family.nrow and 0 <= col < family.ncol):
        raise ValueError(
            f"coord={coord!r} must be a (row, col) pair of integers on the "
            f"{family.nrow}x{family.ncol} map"
        )
    state = row * family.ncol + col
    field = family.slip_param_of(state) if isinstance(family, SplitBridgeFamily) else "slip"
    return list(getattr(theta, field))
