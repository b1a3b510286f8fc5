"""NS-Gym's parameter reads (``env.unwrapped.masspole``, FrozenLake's ``P``) as views onto θ.

In NS-Gym the wrapper writes each new parameter value onto the env you wrapped, so
``env.unwrapped.masspole`` and ``ns_env.unwrapped.masspole`` always show the value in force. In
``ns_pz.compat`` θ lives in the process the wrapper runs; this module makes the same reads show
it:

* :class:`CompatCore` is the ns_pz env a wrapper runs (``ns_env.unwrapped``): NS-Gym's
  attribute names read the current θ from it;
* :func:`adopt` turns those attributes of the env you passed (``env.unwrapped``) into
  read-only views onto the same θ, so stepping that env by hand also uses it.

What a read shows: θ_0 at reset; after a step, the θ that drove that step's transition (NS-Gym
applies a change just before the transition it affects, so its reads show the same values), even
where nature has already chosen the next one. A change by hand (``set_params``) shows once a
transition has used it.
Writes are refused with :class:`ReadOnlyParam`: θ changes through the wrapper's update
functions, or by hand through ``ns_env.unwrapped.set_params``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, SupportsFloat, SupportsIndex

import numpy as np

from ns_pz.compat.envs.Bridge import slip_at
from ns_pz.compat.families import Binding
from ns_pz.compat.tables import transition_table
from ns_pz.envs.bridge import BridgeFamily
from ns_pz.errors import NSPZError
from ns_pz.process import DECISION
from ns_pz.views import NSGymEnv, reset_seeded

_REGION_READERS = ("get_loc_based_prob", "get_loc_basedProb")
"""NS-Gym's names of the Bridge's per-region slip reader."""


class ReadOnlyParam(NSPZError, AttributeError):
    """A write to a parameter that only nature (or ``set_params``) may change."""


class CompatCore(NSGymEnv):
    """The ns_pz env behind an NS-Gym wrapper (its ``unwrapped``), seen as NS-Gym's base env.

    Built like :class:`~ns_pz.views.NSGymEnv`, plus ``binding`` (keyword), the translation
    between NS-Gym's names and the family's θ fields. Build it with :func:`compat_core`, which
    gives it the class name of the env it stands for (``CartPoleEnv``, ``FrozenLakeEnv``,
    ``Bridge``), so code written for NS-Gym, where ``ns_env.unwrapped`` is the base env, reads
    ``TUNABLE_PARAMS[type(ns_env.unwrapped).__name__]``. Its ``observation_space`` is the
    base env's (the wrapper sets the very space of the env it wraps; the family's state space
    until then), and its own ``reset`` and ``step`` return the state alone; the wrapper adds
    NS-Gym's notification dict around it. Unlike stepping NS-Gym's base env by hand, a step
    here is one of the episode the wrapper runs (nature moves as scheduled): θ lives in that
    episode.
    """

    def __init__(
        self, *args: Any, binding: Binding, nature_seeds: Sequence[int] = (), **kwargs: Any
    ) -> None:
        super().__init__(*args, **kwargs)
        self._ns_gym_binding = binding
        self._nature_seeds = tuple(nature_seeds)
        self.observation_space = self.family.observation_space

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Start an episode (see :meth:`ns_pz.views.NSGymEnv.reset`); the state alone.

        With ``seed`` and ``nature_seeds`` (the ``seed=`` arguments of the wrapper's
        schedulers), the env starts from ``seed`` alone and nature draws from both: as in
        NS-Gym, whose reset reseeds update functions but never schedulers, two scheduler seeds
        give two schedules under one reset seed, and the same pair repeats.
        """
        process = reset_seeded(self, self.process, seed, options)
        if seed is not None and self._nature_seeds:
            entropy = np.random.SeedSequence([int(seed), *self._nature_seeds])
            process.nature_rng = np.random.Generator(np.random.PCG64(entropy))
        process.play_until(DECISION)
        return self.family.observe(process.state), self._info()

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """One step of the episode (see :meth:`ns_pz.views.NSGymEnv.step`); the state alone."""
        reward, terminated, truncated = self._advance(action)
        state = self.family.observe(self.process.state)
        return state, float(reward), bool(terminated), bool(truncated), self._info()

    def __reduce_ex__(self, protocol: SupportsIndex) -> tuple[Any, ...]:
        """Copied and pickled through :func:`compat_core`'s class of the same name."""
        return _new_core, (type(self).__name__,), dict(vars(self))

    def ns_gym_attribute(self, name: str) -> Any:
        """The value NS-Gym's env would hold in attribute ``name`` now.

        Raises:
            AttributeError: ``name`` is not one of the binding's readable attributes.
        """
        binding = self._ns_gym_binding
        theta = self.process.last_theta
        if name == binding.table_attribute:
            return transition_table(self.family, theta)
        if name == "theta":
            return theta
        if name in binding.names:
            value = getattr(theta, binding.names[name])
            return list(value) if isinstance(value, tuple) else value
        if name in binding.aliases:
            return self.ns_gym_attribute(binding.aliases[name])
        if name in binding.derived:
            return getattr(theta, name)
        if name in _REGION_READERS and isinstance(self.family, BridgeFamily):
            return self.get_loc_based_prob
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def get_loc_based_prob(self, coord: Sequence[int]) -> list[float]:
        """The Bridge's slip vector in force on the cell ``coord = (row, col)``, as NS-Gym's.

        Also under NS-Gym's first spelling, ``get_loc_basedProb``. Read like the parameters
        (the θ of the last transition); see :meth:`ns_pz.compat.envs.Bridge.get_loc_based_prob`.

        Raises:
            AttributeError: The env is not a Bridge.
            ValueError: ``coord`` is not a ``(row, col)`` pair of integers on the map.
        """
        if not isinstance(self.family, BridgeFamily):
            raise AttributeError(
                f"get_loc_based_prob is the Bridge's; this env runs {self.family!r}"
            )
        return slip_at(self.family, self.process.last_theta, coord)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        return self.ns_gym_attribute(name)

    def __setattr__(self, name: str, value: Any) -> None:
        binding = self.__dict__.get("_ns_gym_binding")
        if binding is not None and name in binding.readable:
            raise read_only(binding, name, "ns_env.unwrapped")
        super().__setattr__(name, value)


def compat_core(binding: Binding, *args: Any, **kwargs: Any) -> CompatCore:
    """A :class:`CompatCore` for ``binding``, of a subclass named as ``binding.env_class``.

    Arguments as for :class:`CompatCore`.
    """
    return _core_class(binding.env_class)(*args, binding=binding, **kwargs)


_CORE_CLASSES: dict[str, type[CompatCore]] = {}
"""Env class name -> the subclass of :class:`CompatCore` of that name."""


def _core_class(name: str) -> type[CompatCore]:
    cls = _CORE_CLASSES.get(name)
    if cls is None:
        doc = f"The ns_pz env behind an NS-Gym wrapper of a {name} (see CompatCore)."
        namespace = {"__module__": __name__, "__qualname__": name, "__doc__": doc}
        cls = _CORE_CLASSES[name] = type(name, (CompatCore,), namespace)
    return cls


def _new_core(name: str) -> CompatCore:
    """An empty :class:`CompatCore` of the class called ``name`` (state set by the caller)."""
    return object.__new__(_core_class(name))  # type: ignore[no-any-return]


def read_only(binding: Binding, name: str, owner: str) -> ReadOnlyParam:
    """The error for a write to ``owner.name``, pointing to the ways θ may change."""
    fields = sorted(binding.names.values()) if name in ("theta", binding.table_attribute) else []
    field = binding.names.get(name) or (fields[0] if fields else name)
    return ReadOnlyParam(
        f"{owner}.{name} is read-only: it shows the parameters of the NS-Gym wrapper's episode, "
        "which change only through nature. Give the wrapper an update function in "
        f"tunable_params to change it over time, or set it by hand during an episode with "
        f"ns_env.unwrapped.set_params({field}=...) (for the next step on); to start from "
        "another value, build a fresh env with it before wrapping"
    )


def adopt(env: Any, core: CompatCore, binding: Binding) -> None:
    """Make ``binding.adopted`` attributes of ``env`` (an unwrapped env) views onto ``core``'s θ.

    ``env``'s class is swapped for a subclass of the same name whose attributes read θ and
    refuse writes; copying or pickling it gives a plain env of the original class holding
    the values of the moment. Wrapping the env again points the views at the new wrapper.
    """
    original = getattr(type(env), "_ns_pz_original", type(env))
    env.__dict__["_ns_pz_core"] = core
    key = (original, binding.family)
    if key not in _ADOPTED:
        _ADOPTED[key] = _adopted_class(original, binding)
    env.__class__ = _ADOPTED[key]


_ADOPTED: dict[tuple[type, str], type] = {}
"""(original class, family name) -> the class of adopted envs."""


def _adopted_class(original: type, binding: Binding) -> type:
    names = binding.adopted

    def view(name: str) -> property:
        def read(self: Any) -> Any:
            return self.__dict__["_ns_pz_core"].ns_gym_attribute(name)

        def write(self: Any, value: Any) -> None:
            raise read_only(binding, name, "env.unwrapped")

        return property(read, write, doc=f"NS-Gym's {name}, read from the wrapper's θ.")

    def reduce(self: Any, protocol: Any) -> tuple[Any, ...]:
        state = {k: v for k, v in vars(self).items() if k != "_ns_pz_core"}
        state.update({name: _plain(getattr(self, name)) for name in names})
        return _rebuild, (original, state)

    namespace: dict[str, Any] = {name: view(name) for name in names}
    namespace.update(
        __module__=original.__module__,
        __qualname__=original.__qualname__,
        __doc__=original.__doc__,
        _ns_pz_original=original,
        __reduce_ex__=reduce,
    )
    return type(original.__name__, (original,), namespace)


def _rebuild(cls: type[Any], state: dict[str, Any]) -> Any:
    env = object.__new__(cls)
    env.__dict__.update(state)
    return env


def _plain(value: Any) -> Any:
    """A value with read-only tables turned into plain dicts and lists (copyable, picklable)."""
    if hasattr(value, "items") and not isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, tuple) and value and isinstance(value[0], tuple):
        return [tuple(entry) for entry in value]
    return value
