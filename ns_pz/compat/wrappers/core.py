"""NS-Gym's wrapper base class (``ns_gym.base.NSWrapper``), as a thin adapter over the core.

A wrapper takes the Gymnasium env you built (``gymnasium.make("CartPole-v1")``), picks the ns_pz
family that implements the same dynamics with its parameters as θ, reads θ_0, the time limit
and the env's settings from it (refusing any it cannot honour, see :mod:`ns_pz.compat.settings`),
and runs a :class:`~ns_pz.compat.attributes.CompatCore` (an :class:`ns_pz.NSGymEnv`) whose
nature is the schedule given in ``tunable_params``. The env you pass is not stepped by the
wrapper: ``wrapper.env`` and ``wrapper.unwrapped`` are the ns_pz env, ``wrapper.base_env`` the
one you passed. Its parameter attributes (``env.unwrapped.masspole``, FrozenLake's ``P``)
become read-only views of the wrapper's θ, as they show the current values in NS-Gym.

Observations have NS-Gym's structure::

    {"state": ..., "env_change": {name: 0/1}, "delta_change": {name: float},
     "relative_time": t}

with one entry per tunable parameter, under NS-Gym's names. ``env_change`` is filled when
``change_notification`` is on, ``delta_change`` when ``delta_change_notification`` is on too;
both report the change applied to the transition just made (a scalar's signed difference, a
slip vector's total-variation distance). ``info`` holds NS-Gym's ground truth keys, the same
two dicts unmasked (``ground_truth_info=False`` leaves them out).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ns_pz.compat.attributes import CompatCore, adopt, compat_core
from ns_pz.compat.base import (
    TUNABLE_PARAMS,
    Reward,
    UpdateDistributionFn,
    UpdateFn,
    explicit_seeds,
    scheduler_seeds,
)
from ns_pz.compat.families import Binding, env_class_name, time_limit
from ns_pz.compat.settings import check_base_env
from ns_pz.errors import ResetNeeded
from ns_pz.family import EnvFamily
from ns_pz.nature import ScriptedNature
from ns_pz.nature import updates as native_updates
from ns_pz.params import SIMPLEX, Params
from ns_pz.process import GroundTruth, NSProcess

__all__ = [
    "GROUND_TRUTH_CHANGE",
    "GROUND_TRUTH_DELTA",
    "NSWrapper",
    "ScalarWrapper",
    "known_kwargs",
]

GROUND_TRUTH_CHANGE = "Ground Truth Env Change"
"""``info`` key: parameter name -> 1 if it changed for this step's transition, else 0 (int)."""
GROUND_TRUTH_DELTA = "Ground Truth Delta Change"
"""``info`` key: parameter name -> size of that change (float; int 0 at reset, as NS-Gym)."""


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
            Change"`` into ``info``, as NS-Gym always does (default); ``False`` leaves ``info``
            empty, so an agent that reads ``info`` cannot see the true changes.

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
        ground_truth_info: bool = True,
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
        settings = check_base_env(env, binding)
        family, theta0 = self._family_and_params(env, binding, settings)
        self._check_tunable(tunable_params, binding, family.params_cls)
        nature = ScriptedNature(
            {binding.names[name]: fn.native() for name, fn in tunable_params.items()}
        )
        level = "none"
        if change_notification:
            level = "detailed" if delta_change_notification else "basic"
        core = compat_core(
            binding,
            family,
            params=theta0,
            nature=nature,
            notification=level,
            max_episode_steps=time_limit(env),
            nature_seeds=[seed for fn in tunable_params.values() for seed in scheduler_seeds(fn)],
        )
        # NS-Gym's ``ns_env.unwrapped.observation_space`` is the base env's own space.
        core.observation_space = env.unwrapped.observation_space
        super().__init__(core)
        adopt(env.unwrapped, core, binding)
        seeds = [seed for fn in tunable_params.values() for seed in explicit_seeds(fn)]
        self._first_seed: int | None = None
        if seeds:
            state = np.random.SeedSequence(seeds).generate_state(1, np.uint64)
            self._first_seed = int(state[0])
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
        # (NS-Gym name, θ field, the field's change size if a vector: total variation, else None)
        self._fields = tuple(
            (name, spec.name, spec.distance if spec.kind == SIMPLEX else None)
            for name in tunable_params
            for spec in (family.params_cls.spec(binding.names[name]),)
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
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        """The family (built with the env's honoured ``settings``) and θ_0."""
        raise NotImplementedError

    # -- Gymnasium API ------------------------------------------------------------------------
    @property
    def core(self) -> CompatCore:
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
        """Start an episode; a seed reseeds the env and every scheduler and update function.

        Without a seed, the first episode is seeded from the ``seed=`` arguments of the
        schedulers and update functions, if any were given (so NS-Gym code that seeds only
        those reproduces its runs); later unseeded episodes continue from there and differ.
        """
        process = self.process
        if seed is None and self._first_seed is not None:
            seed = self._first_seed
        self._first_seed = None
        if self.persistent_params and process.started:
            options = {**(options or {}), "params": process.last_theta}
            process.carried_nature_memory = copy.deepcopy(process.nature_memory)
        state, _ = self.core.reset(seed=seed, options=options)
        obs = {
            "state": state,
            "env_change": dict(self._zeros_int),
            "delta_change": dict(self._zeros_float),
            "relative_time": 0,
        }
        info: dict[str, Any] = {}
        if self.ground_truth_info:
            info[GROUND_TRUTH_CHANGE] = dict(self._zeros_int)
            info[GROUND_TRUTH_DELTA] = dict(self._zeros_int)
        return obs, info

    def step(  # type: ignore[override]  # NS-Gym's Reward in place of the float on request
        self, action: Any
    ) -> tuple[dict[str, Any], SupportsFloat | Reward, bool, bool, dict[str, Any]]:
        """Parameters change for this step (if scheduled), then the env steps under them."""
        core: CompatCore = self.env  # type: ignore[assignment]  # self.core, without the call
        reward, terminated, truncated = core._advance(action)
        process = core.process
        truth_flags, truth_deltas = self._zeros_int, self._zeros_float
        change = process.last_change
        if change is not None:
            before, after = change
            known = process.last_change_sizes  # a vector's size, when nature's change had it
            truth_flags, truth_deltas = dict(truth_flags), dict(truth_deltas)
            for name, native, vector_distance in self._fields:
                old, new = getattr(before, native), getattr(after, native)
                if old != new:
                    truth_flags[name] = 1
                    if vector_distance is None:
                        truth_deltas[name] = new - old
                    else:
                        size = known.get(native) if known else None
                        truth_deltas[name] = vector_distance(old, new) if size is None else size
        shown_flags, shown_deltas = self._zeros_int, self._zeros_float
        if self.change_notification and not self.frozen:
            shown_flags = truth_flags
            if self.delta_change_notification:
                shown_deltas = truth_deltas
        obs = {
            "state": process.family.observe(process.state),
            "env_change": dict(shown_flags),
            "delta_change": dict(shown_deltas),
            "relative_time": process.t,
        }
        info: dict[str, Any] = {}
        if self.ground_truth_info:  # the truth's own dicts when fresh, never the obs' ones
            info[GROUND_TRUTH_CHANGE] = truth_flags if change else dict(truth_flags)
            info[GROUND_TRUTH_DELTA] = truth_deltas if change else dict(truth_deltas)
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

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled: the env passed (pickled as a plain snapshot) reads this wrapper's θ again."""
        self.__dict__.update(state)
        adopt(self.base_env.unwrapped, self.core, self.binding)

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
            scalar = isinstance(fn, UpdateFn) and not isinstance(fn, UpdateDistributionFn)
            if not vector and not scalar:
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


class ScalarWrapper(NSWrapper):
    """NS-Gym's constructor of the wrappers whose parameters are numbers (classic control, MuJoCo).

    The flags NS-Gym passes through ``**kwargs`` (``scalar_reward``, ``persistent_params``,
    ``ground_truth_info``) are checked by name: any other keyword raises ``TypeError``.
    """

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
            **known_kwargs(kwargs),
        )


_WRAPPER_KWARGS = ("scalar_reward", "persistent_params", "ground_truth_info")


def known_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments :class:`NSWrapper` takes; any other raises (NS-Gym ignores them)."""
    unknown = sorted(set(kwargs) - set(_WRAPPER_KWARGS))
    if unknown:
        raise TypeError(
            f"unexpected keyword argument(s) {unknown}; allowed: {list(_WRAPPER_KWARGS)}"
        )
    return kwargs


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value
