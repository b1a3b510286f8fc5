"""NS-Gym's ``ns_gym.wrappers.toy_text``: FrozenLake, CliffWalking and Bridge wrappers.

θ is the slip vector (``P``; the Bridge split in halves has ``P_left`` and ``P_right``), the
intended move first. As in NS-Gym, the wrapper's ``transition_prob`` is the slip vector in
force, its ``P`` (and ``env.unwrapped.P`` for FrozenLake and CliffWalking) the transition
table ``P[s][a] = [(prob, next_state, reward, terminated), ...]`` under it, and ``info`` holds
``"transition_prob"`` after each step.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, SupportsFloat

import gymnasium as gym
import numpy as np

from ns_pz.compat.base import Reward, UpdateDistributionFn, UpdateFn
from ns_pz.compat.families import (
    BRIDGE,
    CLIFF_WALKING,
    FROZEN_LAKE,
    SPLIT_BRIDGE,
    Binding,
    env_class_name,
)
from ns_pz.compat.tables import Table, transition_table
from ns_pz.compat.wrappers.core import NSWrapper, known_kwargs
from ns_pz.envs.cliff_walking import CliffWalkingFamily, CliffWalkingParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams
from ns_pz.family import EnvFamily
from ns_pz.nature.updates import check_distribution, check_real
from ns_pz.params import Params

__all__ = ["NSBridgeWrapper", "NSCliffWalkingWrapper", "NSFrozenLakeWrapper"]


class _GridWrapper(NSWrapper):
    """Grid worlds: θ is the slip vector ``P`` (the intended move first)."""

    _slip_doc: ClassVar[str] = ""
    _default_slip: ClassVar[tuple[float, ...]] = (1.0, 0.0, 0.0)

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        initial_prob_dist: Sequence[float] | None = None,
        modified_rewards: Mapping[str, float] | None = None,
        **kwargs: Any,
    ) -> None:
        self._initial_prob_dist = initial_prob_dist
        self._modified_rewards = modified_rewards
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            **known_kwargs(kwargs),
        )
        first = self.process.theta0
        self.initial_prob_dist = list(getattr(first, first.names()[0]))
        self.modified_rewards = modified_rewards
        names = self.binding.names
        self._slip_field = next(iter(names.values())) if len(names) == 1 else None
        """The θ field of the slip vector, unless the vector is split (the Bridge's halves)."""

    def _initial_slip(self) -> tuple[float, ...]:
        """θ_0's slip vector: ``initial_prob_dist``, or the class default when it is None."""
        initial = self._initial_prob_dist
        return self._initial(
            self._default_slip if initial is None else initial, len(self._default_slip)
        )

    def _initial(self, initial_prob_dist: object, size: int) -> tuple[float, ...]:
        vector = check_distribution("initial_prob_dist", initial_prob_dist)
        if len(vector) != size:
            raise ValueError(
                f"initial_prob_dist={list(vector)!r} has {len(vector)} elements; "
                f"{type(self).__name__} needs {size} {self._slip_doc}"
            )
        return vector

    @property
    def transition_prob(self) -> list[float] | dict[str, list[float]]:
        """The slip vector in force (split Bridge: ``{"P_left": ..., "P_right": ...}``)."""
        field = self._slip_field
        if field is not None:  # read at every step (info): straight from θ
            return list(getattr(self.env.process.last_theta, field))  # type: ignore[attr-defined]
        return self.get_params()

    @property
    def P(self) -> Table:  # noqa: N802 - NS-Gym's name
        """The transition table ``P[s][a] = [(prob, next_state, reward, terminated), ...]`` now."""
        return transition_table(self.core.family, self.process.last_theta)

    def step(  # type: ignore[override]
        self, action: Any
    ) -> tuple[dict[str, Any], SupportsFloat | Reward, bool, bool, dict[str, Any]]:
        """As :meth:`NSWrapper.step`; ``info["transition_prob"]`` is the slip vector in force."""
        result = super().step(action)
        result[4]["transition_prob"] = self.transition_prob
        return result


class NSFrozenLakeWrapper(_GridWrapper):
    """FrozenLake-v1 (any map) with the slip vector ``P = [intended, action+1, action-1]``.

    Args:
        initial_prob_dist: θ_0's slip vector, default ``[1, 0, 0]`` (the base env's
            ``is_slippery`` is ignored, as in NS-Gym).
        modified_rewards: Reward for entering each cell letter (``"G"``, ``"H"``, ``"F"``, and
            ``"S"`` equal to ``"F"``); letters not given keep the env's ``reward_schedule``
            (Gymnasium's default: 1 for the goal, 0 elsewhere; NS-Gym ignores the env's).
        Other arguments: see :class:`NSWrapper`.
    """

    _accepts = "gymnasium.make('FrozenLake-v1', ...)"
    _slip_doc = "([intended, action+1, action-1])"

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        if env_class_name(env) != FROZEN_LAKE.env_class:
            raise self._unsupported(env, [FROZEN_LAKE.env_class])
        return FROZEN_LAKE

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        goal, hole, frozen = settings.get("reward_schedule", (1.0, 0.0, 0.0))
        rewards = _rewards(self._modified_rewards, {"G": goal, "H": hole, "F": frozen, "S": frozen})
        desc = [
            "".join(c.decode() if isinstance(c, bytes) else str(c) for c in row)
            for row in env.unwrapped.desc  # type: ignore[attr-defined]
        ]
        family = FrozenLakeFamily(
            desc=desc, reward_schedule=(rewards["G"], rewards["H"], rewards["F"])
        )
        return family, FrozenLakeParams(slip=self._initial_slip())


class NSCliffWalkingWrapper(_GridWrapper):
    """CliffWalking-v1 with the slip vector ``P = [intended, action+1, action-1, reverse]``.

    Args:
        initial_prob_dist: θ_0's slip vector, default ``[1, 0, 0, 0]``.
        modified_rewards: Reward for entering each cell letter: ``"H"`` (the cliff, default
            -100), ``"G"`` (default 0), ``"F"`` and ``"S"`` (default -1, equal to each other).
        terminal_cliff: Stepping into the cliff also ends the episode (the agent is put back on
            the start cell either way).
        Other arguments: see :class:`NSWrapper`.
    """

    _accepts = "gymnasium.make('CliffWalking-v1') (not slippery)"
    _slip_doc = "([intended, action+1, action-1, reverse])"
    _default_slip = (1.0, 0.0, 0.0, 0.0)

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        initial_prob_dist: Sequence[float] | None = None,
        modified_rewards: Mapping[str, float] | None = None,
        terminal_cliff: bool = False,
        **kwargs: Any,
    ) -> None:
        if not isinstance(terminal_cliff, (bool, np.bool_)):
            raise TypeError(f"terminal_cliff={terminal_cliff!r} must be a bool")
        self.terminal_cliff = bool(terminal_cliff)
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            initial_prob_dist,
            modified_rewards,
            **kwargs,
        )

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        if env_class_name(env) != CLIFF_WALKING.env_class:
            raise self._unsupported(env, [CLIFF_WALKING.env_class])
        if getattr(env.unwrapped, "is_slippery", False):
            raise ValueError(
                "env is slippery; build it with gymnasium.make('CliffWalking-v1', "
                "is_slippery=False): the wrapper's initial_prob_dist and schedule set the slip"
            )
        return CLIFF_WALKING

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        rewards = _rewards(self._modified_rewards, {"H": -100.0, "G": 0.0, "F": -1.0, "S": -1.0})
        family = CliffWalkingFamily(
            goal_reward=rewards["G"],
            cliff_reward=rewards["H"],
            step_reward=rewards["F"],
            terminal_cliff=self.terminal_cliff,
        )
        return family, CliffWalkingParams(slip=self._initial_slip())


class NSBridgeWrapper(_GridWrapper):
    """The Bridge (``gymnasium.make("ns_pz_compat/Bridge-v0")``) with slip vector(s) as θ.

    ``P`` is the global slip vector ``[intended, action+1, action-1]``; in split mode (a Bridge
    built with ``split_probs=True``, or ``tunable_params`` naming ``P_left`` or ``P_right``,
    which switches the Bridge to it as NS-Gym does) the parameters are ``P_left`` and
    ``P_right``, both starting from ``initial_prob_dist`` (or from ``(left, right)``, a pair of
    vectors). Without ``initial_prob_dist`` they start from the Bridge's own (its
    ``global_init_probs``, or what you set as ``env.unwrapped.P``; NS-Gym's default
    ``[1, 0, 0]`` is the Bridge's default too). ``modified_rewards`` must be ``None``: the
    Bridge's rewards are fixed (NS-Gym accepts and ignores it).
    """

    _accepts = "gymnasium.make('ns_pz_compat/Bridge-v0')"
    _slip_doc = "([intended, action+1, action-1])"

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        initial_prob_dist: Sequence[float] | None = None,
        modified_rewards: Mapping[str, float] | None = None,
        **kwargs: Any,
    ) -> None:
        if modified_rewards is not None:
            raise ValueError(
                f"modified_rewards={modified_rewards!r}: the Bridge's rewards are fixed (+1 goal, "
                "-1 hole, 0 elsewhere); pass None"
            )
        split_names = {"P_left", "P_right"}
        if isinstance(tunable_params, Mapping) and split_names & set(tunable_params):
            if env_class_name(env) == BRIDGE.env_class and hasattr(env.unwrapped, "split"):
                env.unwrapped.split()
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            initial_prob_dist,
            None,
            **kwargs,
        )

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        if env_class_name(env) != BRIDGE.env_class or not hasattr(env.unwrapped, "family"):
            raise self._unsupported(env, ["Bridge (ns_pz.compat.envs.Bridge)"])
        return SPLIT_BRIDGE if env.unwrapped.split_probs else BRIDGE  # type: ignore[attr-defined]

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        family: EnvFamily = env.unwrapped.family  # type: ignore[attr-defined]
        initial = self._initial_prob_dist
        if initial is None:
            return family, env.unwrapped.theta  # type: ignore[attr-defined]
        names = family.params_cls.names()
        pair = isinstance(initial, tuple) and len(initial) == 2
        if pair and all(isinstance(v, Sequence) for v in initial) and len(names) == 2:
            left, right = (self._initial(v, 3) for v in initial)  # type: ignore[arg-type]
            return family, family.params_cls(**dict(zip(names, (left, right), strict=True)))
        slip = self._initial(initial, 3)
        return family, family.params_cls(**dict.fromkeys(names, slip))


def _rewards(modified: Mapping[str, float] | None, defaults: dict[str, float]) -> dict[str, float]:
    """Cell-letter rewards: ``defaults`` updated by ``modified``, checked."""
    if modified is None:
        return defaults
    if not isinstance(modified, Mapping):
        raise TypeError(f"modified_rewards={modified!r} must be a dict of cell letter to reward")
    unknown = sorted(set(modified) - set(defaults))
    if unknown:
        raise ValueError(
            f"modified_rewards has cell letters {unknown}; allowed: {sorted(defaults)}"
        )
    rewards = {
        **defaults,
        **{k: check_real(f"modified_rewards[{k!r}]", v) for k, v in modified.items()},
    }
    if rewards["S"] != rewards["F"]:
        raise ValueError(
            f"modified_rewards gives 'S' {rewards['S']!r} but 'F' {rewards['F']!r}; entering the "
            "start cell is rewarded as a free cell here, so they must be equal"
        )
    return rewards
