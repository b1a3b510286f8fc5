"""NS-Gym's wrappers (``ns_gym.wrappers``), as thin adapters over the ns_pz core.

A wrapper takes the Gymnasium env you built (``gymnasium.make("CartPole-v1")``), picks the ns_pz
family that implements the same dynamics with its parameters as θ, reads θ_0 and the time limit
from it, and runs an :class:`ns_pz.NSGymEnv` whose nature is the schedule given in
``tunable_params``. The env you pass is read, never stepped: ``wrapper.env`` (and ``unwrapped``)
is the ns_pz core env, ``wrapper.base_env`` the one you passed.

Observations have NS-Gym's structure::

    {"state": ..., "env_change": {name: 0/1}, "delta_change": {name: float},
     "relative_time": t}

with one entry per tunable parameter, under NS-Gym's names. ``env_change`` is filled when
``change_notification`` is on, ``delta_change`` when ``delta_change_notification`` is on too;
both report the change applied to the transition just made (a scalar's signed difference, a
slip vector's total-variation distance). ``info`` is empty unless ``ground_truth_info=True``.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ns_pz.compat.base import TUNABLE_PARAMS, Reward, UpdateDistributionFn, UpdateFn
from ns_pz.compat.families import (
    BRIDGE,
    CLASSIC_CONTROL,
    CLIFF_WALKING,
    FROZEN_LAKE,
    SPLIT_BRIDGE,
    Binding,
    classic_control_params,
    env_class_name,
    time_limit,
)
from ns_pz.envs.cliff_walking import CliffWalkingFamily, CliffWalkingParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams
from ns_pz.errors import ResetNeeded
from ns_pz.family import EnvFamily
from ns_pz.nature import ScriptedNature
from ns_pz.nature import updates as native_updates
from ns_pz.nature.distribution_updates import total_variation
from ns_pz.nature.updates import check_distribution, check_real
from ns_pz.params import SIMPLEX, Params
from ns_pz.process import GroundTruth, NSProcess
from ns_pz.views import NSGymEnv

__all__ = [
    "NSBridgeWrapper",
    "NSClassicControlWrapper",
    "NSCliffWalkingWrapper",
    "NSFrozenLakeWrapper",
    "NSWrapper",
]

GROUND_TRUTH_CHANGE = "Ground Truth Env Change"
GROUND_TRUTH_DELTA = "Ground Truth Delta Change"


class NSWrapper(gym.Wrapper[dict[str, Any], Any, dict[str, Any], Any]):
    """What every NS-Gym wrapper shares.

    Args:
        env: The Gymnasium env to make non-stationary (read, not stepped).
        tunable_params: NS-Gym parameter name -> ``ns_pz.compat`` update function.
        change_notification: Tell the agent which parameters changed (``env_change``).
        delta_change_notification: Also tell it by how much (``delta_change``); needs
            ``change_notification``. It also makes planning envs use the current parameters.
        in_sim_change: Let the parameters keep changing inside planning envs.
        scalar_reward: Return the reward as a float (else a :class:`~ns_pz.compat.base.Reward`).
        persistent_params: Keep the parameters and the schedule's progress across resets.
        ground_truth_info: Put NS-Gym's ``"Ground Truth Env Change"`` and ``"Ground Truth Delta
            Change"`` into ``info`` (NS-Gym always does; for evaluation code only).

    Raises:
        TypeError / ValueError: Any argument NS-Gym would refuse, and the ones it silently
            accepts (an unknown keyword, a vector that is not a distribution, a parameter the env
            does not have), before anything runs.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        *,
        scalar_reward: bool = True,
        persistent_params: bool = False,
        ground_truth_info: bool = False,
    ) -> None:
        flags = {
            "change_notification": change_notification,
            "delta_change_notification": delta_change_notification,
            "in_sim_change": in_sim_change,
            "scalar_reward": scalar_reward,
            "persistent_params": persistent_params,
            "ground_truth_info": ground_truth_info,
        }
        for name, value in flags.items():
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{name}={value!r} must be a bool")
        if delta_change_notification and not change_notification:
            raise ValueError(
                "delta_change_notification=True needs change_notification=True "
                "(sizes are only shown with the flags)"
            )
        binding = self._binding(env)
        family, theta0 = self._family_and_params(env, binding)
        self._check_tunable(tunable_params, binding, family.params_cls)
        nature = ScriptedNature(
            {binding.names[name]: fn.native() for name, fn in tunable_params.items()}
        )
        level = "none"
        if change_notification:
            level = "detailed" if delta_change_notification else "basic"
        core = NSGymEnv(
            family,
            params=theta0,
            nature=nature,
            notification=level,
            max_episode_steps=time_limit(env),
        )
        super().__init__(core)
        self.base_env = env
        self.binding = binding
        self.tunable_params = dict(tunable_params)
        self.change_notification = bool(change_notification)
        self.delta_change_notification = bool(delta_change_notification)
        self.in_sim_change = bool(in_sim_change)
        self.scalar_reward = bool(scalar_reward)
        self.persistent_params = bool(persistent_params)
        self.ground_truth_info = bool(ground_truth_info)
        self.is_sim_env = False
        self.frozen = False
        self._fields = tuple(
            (name, binding.names[name], family.params_cls.spec(binding.names[name]).kind == SIMPLEX)
            for name in tunable_params
        )
        self._zeros_int = dict.fromkeys(tunable_params, 0)
        self._zeros_float = dict.fromkeys(tunable_params, 0.0)
        self.observation_space = spaces.Dict(
            {
                "state": family.observation_space,
                "env_change": spaces.Dict({p: spaces.Discrete(2) for p in tunable_params}),
                "delta_change": spaces.Dict(
                    {p: spaces.Box(-np.inf, np.inf, (), np.float32) for p in tunable_params}
                ),
                "relative_time": spaces.Box(0.0, np.inf, (), np.float32),
            }
        )

    # -- what subclasses define ---------------------------------------------------------------
    _accepts: ClassVar[str] = ""
    """What the wrapper takes, for error messages."""

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        raise NotImplementedError

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding
    ) -> tuple[EnvFamily, Params]:
        raise NotImplementedError

    # -- Gymnasium API ------------------------------------------------------------------------
    @property
    def core(self) -> NSGymEnv:
        """The ns_pz env doing the work."""
        return self.env  # type: ignore[return-value]

    @property
    def process(self) -> NSProcess:
        """The core's process (θ, time, ground truth)."""
        return self.core.process

    @property
    def t(self) -> int:
        """Transitions since reset (NS-Gym's ``t``)."""
        return self.process.t

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode; a seed reseeds the env and every scheduler and update function."""
        process = self.process
        if self.persistent_params and process.started:
            options = {**(options or {}), "params": process.last_theta}
            process.carried_nature_memory = copy.deepcopy(process.nature_memory)
        core_obs, _ = self.core.reset(seed=seed, options=options)
        obs = {
            "state": core_obs["state"],
            "env_change": dict(self._zeros_int),
            "delta_change": dict(self._zeros_float),
            "relative_time": 0,
        }
        info: dict[str, Any] = {}
        if self.ground_truth_info:
            info[GROUND_TRUTH_CHANGE] = dict(self._zeros_int)
            info[GROUND_TRUTH_DELTA] = dict(self._zeros_float)
        return obs, info

    def step(  # type: ignore[override]  # NS-Gym's Reward in place of the float on request
        self, action: Any
    ) -> tuple[dict[str, Any], SupportsFloat | Reward, bool, bool, dict[str, Any]]:
        """Parameters change for this step (if scheduled), then the env steps under them."""
        core_obs, reward, terminated, truncated, _ = self.core.step(action)
        process = self.process
        truth_flags, truth_deltas = self._zeros_int, self._zeros_float
        change = process.last_change
        if change is not None:
            before, after = change
            truth_flags, truth_deltas = dict(truth_flags), dict(truth_deltas)
            for name, native, is_vector in self._fields:
                old, new = getattr(before, native), getattr(after, native)
                if old != new:
                    truth_flags[name] = 1
                    truth_deltas[name] = total_variation(old, new) if is_vector else new - old
        shown_flags, shown_deltas = self._zeros_int, self._zeros_float
        if self.change_notification and not self.frozen:
            shown_flags = truth_flags
            if self.delta_change_notification:
                shown_deltas = truth_deltas
        obs = {
            "state": core_obs["state"],
            "env_change": dict(shown_flags),
            "delta_change": dict(shown_deltas),
            "relative_time": process.t,
        }
        info: dict[str, Any] = {}
        if self.ground_truth_info:
            info[GROUND_TRUTH_CHANGE] = dict(truth_flags)
            info[GROUND_TRUTH_DELTA] = dict(truth_deltas)
        value: SupportsFloat | Reward = float(reward)
        if not self.scalar_reward:
            value = Reward(float(reward), obs["env_change"], obs["delta_change"], process.t)
        return obs, value, bool(terminated), bool(truncated), info

    # -- NS-Gym's extras ----------------------------------------------------------------------
    def freeze(self, mode: bool = True) -> NSWrapper:
        """Hide notifications (parameters still change, as in NS-Gym); returns the wrapper."""
        self.frozen = bool(mode)
        return self

    def unfreeze(self) -> NSWrapper:
        """Show notifications again; returns the wrapper."""
        self.frozen = False
        return self

    def get_default_params(self) -> dict[str, Any]:
        """NS-Gym's ``TUNABLE_PARAMS`` entry for this env: every tunable name and its default."""
        return TUNABLE_PARAMS[self.binding.env_class]

    def get_params(self) -> dict[str, Any]:
        """The parameters of the last transition (θ_0 before one), under NS-Gym's names.

        Vectors are lists. Nature has already chosen the θ of the coming transition when a step
        returns; like NS-Gym, this shows the one the last step ran under.
        """
        theta = self.process.last_theta
        return {name: _plain(getattr(theta, native)) for name, native in self.binding.names.items()}

    def ground_truth(self) -> GroundTruth:
        """The true θ trajectory of this episode (ns_pz names), for evaluation."""
        return self.core.ground_truth()

    def get_planning_env(self) -> NSWrapper:
        """A copy at the current state and time for planning (a "sim env").

        Its parameters are the initial ones, or the current ones when
        ``delta_change_notification`` is on or this env is itself a sim env; they stay fixed
        unless ``in_sim_change``. It continues the clock and the time limit, and draws from its
        own generator derived from this env's seed (NS-Gym reseeds from OS entropy).

        Raises:
            ResetNeeded: Called before the first reset.
        """
        process = self.process
        if not process.started:
            raise ResetNeeded("get_planning_env() called before reset(); call reset() first")
        current = self.is_sim_env or self.delta_change_notification
        return self._sim_copy(process.last_theta if current else process.theta0)

    def _sim_copy(self, theta: Params) -> NSWrapper:
        twin = copy.copy(self)
        # NS-Gym's sim env applies the schedule at its own first step: nature moves again there.
        twin.env = self.core.branch(
            theta=theta, keep_nature=self.in_sim_change, retake_turn=self.in_sim_change
        )
        twin.is_sim_env = True
        return twin

    def __deepcopy__(self, memo: dict[int, Any]) -> NSWrapper:
        """A sim env with the current parameters (as NS-Gym's); before reset, a plain copy."""
        if self.process.started:
            return self._sim_copy(self.process.last_theta)
        twin = copy.copy(self)
        twin.env = copy.deepcopy(self.core, memo)
        return twin

    # -- construction helpers -----------------------------------------------------------------
    def _check_tunable(
        self, tunable_params: object, binding: Binding, params_cls: type[Params]
    ) -> None:
        if not isinstance(tunable_params, Mapping):
            raise TypeError(
                f"tunable_params={tunable_params!r} must be a dict of parameter name to update "
                "function"
            )
        allowed = sorted(binding.names)
        for name, fn in tunable_params.items():
            if name not in binding.names:
                raise ValueError(
                    f"tunable_params has {name!r}, which {binding.env_class} does not have; "
                    f"tunable: {allowed}"
                )
            if isinstance(fn, (native_updates.UpdateFn, native_updates.DistributionUpdateFn)):
                raise TypeError(
                    f"tunable_params[{name!r}]={fn!r} is a native ns_pz update function; use the "
                    "ns_pz.compat.update_functions classes here (or ns_pz.NSGymEnv with a "
                    "ScriptedNature for native ones)"
                )
            vector = params_cls.spec(binding.names[name]).kind == SIMPLEX
            if vector and not isinstance(fn, UpdateDistributionFn):
                raise TypeError(
                    f"tunable_params[{name!r}]={fn!r} must be a distribution update function "
                    f"({name!r} is a probability vector), e.g. DistributionDecrementUpdate"
                )
            if not vector and not isinstance(fn, UpdateFn):
                raise TypeError(
                    f"tunable_params[{name!r}]={fn!r} must be a scalar update function "
                    f"({name!r} is a number), e.g. IncrementUpdate"
                )

    def _unsupported(self, env: gym.Env[Any, Any], supported: Sequence[str]) -> ValueError:
        return ValueError(
            f"{type(self).__name__} takes {self._accepts}; got an env of class "
            f"{env_class_name(env)} (supported classes: {', '.join(supported)})"
        )

    def __repr__(self) -> str:
        return f"<{type(self).__name__}<{self.base_env}>>"

    __str__ = __repr__


class NSClassicControlWrapper(NSWrapper):
    """CartPole-v1, MountainCar-v0, MountainCarContinuous-v0, Acrobot-v1 or Pendulum-v1.

    θ_0 is read from the env's attributes (``masspole``, ``LINK_LENGTH_1``, ``m``, ...), so an
    env whose constants you changed starts from them. A change that would leave the physical
    range (a negative mass) is projected onto it (NS-Gym rejects the change with a warning).
    """

    _accepts = "a classic-control env (gymnasium.make('CartPole-v1'), ...)"

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        **kwargs: Any,
    ) -> None:
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            **_known(kwargs),
        )

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        binding = CLASSIC_CONTROL.get(env_class_name(env))
        if binding is None:
            raise self._unsupported(env, list(CLASSIC_CONTROL))
        return binding

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding
    ) -> tuple[EnvFamily, Params]:
        family_cls = binding.family_class()
        kwargs = {}
        if binding.env_class == "CartPoleEnv":
            kwargs["kinematics_integrator"] = env.unwrapped.kinematics_integrator  # type: ignore[attr-defined]
        family = family_cls(**kwargs)
        return family, family.params_cls.from_mapping(classic_control_params(binding, env))


class _GridWrapper(NSWrapper):
    """Grid worlds: θ is the slip vector ``P`` (the intended move first)."""

    _slip_doc: ClassVar[str] = ""

    def _initial(self, initial_prob_dist: object, size: int) -> tuple[float, ...]:
        vector = check_distribution("initial_prob_dist", initial_prob_dist)
        if len(vector) != size:
            raise ValueError(
                f"initial_prob_dist={list(vector)!r} has {len(vector)} elements; "
                f"{type(self).__name__} needs {size} {self._slip_doc}"
            )
        return vector


class NSFrozenLakeWrapper(_GridWrapper):
    """FrozenLake-v1 (any map) with the slip vector ``P = [intended, action+1, action-1]``.

    Args:
        initial_prob_dist: θ_0's slip vector (the base env's ``is_slippery`` is ignored, as in
            NS-Gym).
        modified_rewards: Reward for entering each cell letter (``"G"``, ``"H"``, ``"F"``, and
            ``"S"`` equal to ``"F"``); default 1 for the goal, 0 elsewhere.
        Other arguments: see :class:`NSWrapper`.
    """

    _accepts = "gymnasium.make('FrozenLake-v1', ...)"
    _slip_doc = "([intended, action+1, action-1])"

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        initial_prob_dist: Sequence[float] = (1.0, 0.0, 0.0),
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
            **_known(kwargs),
        )
        self.initial_prob_dist = list(self.process.theta0.slip)  # type: ignore[attr-defined]
        self.modified_rewards = modified_rewards

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        if env_class_name(env) != FROZEN_LAKE.env_class:
            raise self._unsupported(env, [FROZEN_LAKE.env_class])
        return FROZEN_LAKE

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding
    ) -> tuple[EnvFamily, Params]:
        rewards = _rewards(self._modified_rewards, {"G": 1.0, "H": 0.0, "F": 0.0, "S": 0.0})
        desc = [
            "".join(c.decode() if isinstance(c, bytes) else str(c) for c in row)
            for row in env.unwrapped.desc  # type: ignore[attr-defined]
        ]
        family = FrozenLakeFamily(
            desc=desc, reward_schedule=(rewards["G"], rewards["H"], rewards["F"])
        )
        return family, FrozenLakeParams(slip=self._initial(self._initial_prob_dist, 3))


class NSCliffWalkingWrapper(_GridWrapper):
    """CliffWalking-v1 with the slip vector ``P = [intended, action+1, action-1, reverse]``.

    Args:
        initial_prob_dist: θ_0's slip vector.
        modified_rewards: Reward for entering each cell letter: ``"H"`` (the cliff, default
            -100), ``"G"`` (default 0), ``"F"`` and ``"S"`` (default -1, equal to each other).
        terminal_cliff: Stepping into the cliff also ends the episode (the agent is put back on
            the start cell either way).
        Other arguments: see :class:`NSWrapper`.
    """

    _accepts = "gymnasium.make('CliffWalking-v1') (not slippery)"
    _slip_doc = "([intended, action+1, action-1, reverse])"

    def __init__(
        self,
        env: gym.Env[Any, Any],
        tunable_params: Mapping[str, UpdateFn | UpdateDistributionFn],
        change_notification: bool = False,
        delta_change_notification: bool = False,
        in_sim_change: bool = False,
        initial_prob_dist: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
        modified_rewards: Mapping[str, float] | None = None,
        terminal_cliff: bool = False,
        **kwargs: Any,
    ) -> None:
        if not isinstance(terminal_cliff, (bool, np.bool_)):
            raise TypeError(f"terminal_cliff={terminal_cliff!r} must be a bool")
        self._initial_prob_dist = initial_prob_dist
        self._modified_rewards = modified_rewards
        self.terminal_cliff = bool(terminal_cliff)
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            **_known(kwargs),
        )
        self.initial_prob_dist = list(self.process.theta0.slip)  # type: ignore[attr-defined]
        self.modified_rewards = modified_rewards

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
        self, env: gym.Env[Any, Any], binding: Binding
    ) -> tuple[EnvFamily, Params]:
        rewards = _rewards(self._modified_rewards, {"H": -100.0, "G": 0.0, "F": -1.0, "S": -1.0})
        family = CliffWalkingFamily(
            goal_reward=rewards["G"],
            cliff_reward=rewards["H"],
            step_reward=rewards["F"],
            terminal_cliff=self.terminal_cliff,
        )
        return family, CliffWalkingParams(slip=self._initial(self._initial_prob_dist, 4))


class NSBridgeWrapper(_GridWrapper):
    """The Bridge (``gymnasium.make("ns_pz_compat/Bridge-v0")``) with slip vector(s) as θ.

    ``P`` is the global slip vector ``[intended, action+1, action-1]``; with a Bridge built with
    ``split_probs=True`` the parameters are ``P_left`` and ``P_right``, both starting from
    ``initial_prob_dist``. ``modified_rewards`` must be ``None``: the Bridge's rewards are fixed
    (NS-Gym accepts and ignores it).
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
        initial_prob_dist: Sequence[float] = (1.0, 0.0, 0.0),
        modified_rewards: Mapping[str, float] | None = None,
        **kwargs: Any,
    ) -> None:
        if modified_rewards is not None:
            raise ValueError(
                f"modified_rewards={modified_rewards!r}: the Bridge's rewards are fixed (+1 goal, "
                "-1 hole, 0 elsewhere); pass None"
            )
        self._initial_prob_dist = initial_prob_dist
        super().__init__(
            env,
            tunable_params,
            change_notification,
            delta_change_notification,
            in_sim_change,
            **_known(kwargs),
        )
        self.initial_prob_dist = list(self._initial(initial_prob_dist, 3))
        self.modified_rewards = None

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        if env_class_name(env) != BRIDGE.env_class or not hasattr(env.unwrapped, "family"):
            raise self._unsupported(env, ["Bridge (ns_pz.compat.envs.Bridge)"])
        return SPLIT_BRIDGE if env.unwrapped.split_probs else BRIDGE  # type: ignore[attr-defined]

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding
    ) -> tuple[EnvFamily, Params]:
        family: EnvFamily = env.unwrapped.family  # type: ignore[attr-defined]
        slip = self._initial(self._initial_prob_dist, 3)
        names = family.params_cls.names()
        return family, family.params_cls(**dict.fromkeys(names, slip))


_WRAPPER_KWARGS = ("scalar_reward", "persistent_params", "ground_truth_info")


def _known(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments :class:`NSWrapper` takes; any other raises (NS-Gym ignores them)."""
    unknown = sorted(set(kwargs) - set(_WRAPPER_KWARGS))
    if unknown:
        raise TypeError(
            f"unexpected keyword argument(s) {unknown}; allowed: {list(_WRAPPER_KWARGS)}"
        )
    return kwargs


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


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value
