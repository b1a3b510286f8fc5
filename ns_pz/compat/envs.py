"""NS-Gym's own environment, the Bridge, as a plain Gymnasium env over ns_pz's Bridge family.

Registered with Gymnasium as ``ns_pz_compat/Bridge-v0`` (NS-Gym's is ``ns_gym/Bridge-v0``; the
separate namespace lets both packages be installed together). Unlike NS-Gym's, it draws its
slips from the env's own seeded generator, so ``reset(seed=...)`` reproduces a run and
``gymnasium.utils.env_checker.check_env`` passes, and ``info`` is empty.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, SupportsFloat

import gymnasium as gym

from ns_pz.envs.bridge import BridgeFamily, SplitBridgeFamily
from ns_pz.nature.updates import check_distribution, check_real
from ns_pz.params import Params

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
