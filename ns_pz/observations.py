"""Observation and action spaces of the three agents, and the builders of their observations.

Decision agent (and the Gymnasium view), a flat ``Dict``:

* ``state``: the base environment's observation;
* ``env_change``: ``MultiBinary(n)``, one flag per parameter in θ's field order;
* ``delta_change``: ``Box(0, inf, (n,), float32)``, the size of each parameter's change;
* ``relative_time``: ``Box(0, inf, (1,), float32)``, transitions since reset.

Nature: see :mod:`ns_pz.nature.interface` (one encoding for the game and every learner).

Monitor: a ``Dict`` of the last transition (``last_state``, ``last_action``, ``last_reward``,
``state``) and ``relative_time`` (for a learned monitor with
:class:`~ns_pz.monitor.MonitorFeatures`, a normalised ``clock`` and a ``memory`` of evidence
instead of ``relative_time``); it acts with a ``Dict`` of ``env_change`` and
``delta_change``, the notification it wants the agent to get, or (for learners and libraries
that refuse ``Dict`` actions) with the flags alone, ``MultiDiscrete([2] * n)``.

Every call returns fresh arrays: users may keep or modify what they are given.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from ns_pz.family import EnvFamily
from ns_pz.params import Params

if TYPE_CHECKING:
    from ns_pz.monitor.features import MonitorFeatures
    from ns_pz.process import NSProcess


def agent_observation_space(family: EnvFamily) -> spaces.Dict:
    """The decision agent's observation space; independent of the notification level."""
    count = len(family.params_cls.names())
    return spaces.Dict(
        {
            "state": family.observation_space,
            "env_change": spaces.MultiBinary(count),
            "delta_change": spaces.Box(0.0, np.inf, (count,), np.float32),
            "relative_time": _CLOCK,
        }
    )


def monitor_observation_space(
    family: EnvFamily, features: MonitorFeatures | None = None
) -> spaces.Dict:
    """The last transition and the clock; with ``features``, the normalised clock and memory."""
    space = spaces.Dict(
        {
            "last_state": family.observation_space,
            "last_action": family.action_space,
            "last_reward": spaces.Box(-np.inf, np.inf, (1,), np.float32),
            "state": family.observation_space,
            "relative_time": _CLOCK,
        }
    )
    return space if features is None else features.observation_space(space)


def monitor_action_space(params_cls: type[Params]) -> spaces.Dict:
    """The notification the monitor sends: flags and sizes, one per parameter."""
    count = len(params_cls.names())
    return spaces.Dict(
        {
            "env_change": spaces.MultiBinary(count),
            "delta_change": spaces.Box(0.0, np.inf, (count,), np.float32),
        }
    )


def monitor_flags_space(params_cls: type[Params]) -> spaces.MultiDiscrete:
    """The notification as flags alone, one 0/1 per parameter (no sizes), for learners."""
    return spaces.MultiDiscrete(np.full(len(params_cls.names()), 2, np.int64))


class ObservationBuilder:
    """Builds the three agents' observations for one family."""

    def __init__(self, family: EnvFamily) -> None:
        count = len(family.params_cls.names())
        self._observe = family.observe
        self._null_action = _null_element(family.action_space)
        self._zero_flags = np.zeros(count, np.int8)
        self._zero_sizes = np.zeros(count, np.float32)
        self._zero_clock = np.zeros(1, np.float32)
        self._flag_arrays: dict[tuple, np.ndarray] = {}
        self._in_bounds = _BoundedCopy(family.action_space)

    def agent(self, state: Any, t: int, flags: tuple, sizes: tuple, no_change: tuple) -> dict:
        """The decision agent's observation: one flag and one size per parameter.

        ``no_change`` is the process's all-zero tuple: flags or sizes that are it become a copy
        of a zero template (cheaper than converting a tuple); so do flags seen before.
        """
        clock = self._zero_clock.copy()
        clock[0] = t
        return {
            "state": self._observe(state),
            "env_change": self._zero_flags.copy()
            if flags is no_change
            else self._flags_array(flags),
            "delta_change": self._zero_sizes.copy()
            if sizes is no_change
            else self._sizes_array(sizes),
            "relative_time": clock,
        }

    def notification(self, flags: tuple, sizes: tuple, no_change: tuple) -> tuple:
        """New ``env_change`` (int8) and ``delta_change`` (float32) arrays, as :meth:`agent`."""
        return (
            self._zero_flags.copy() if flags is no_change else self._flags_array(flags),
            self._zero_sizes.copy() if sizes is no_change else self._sizes_array(sizes),
        )

    def _sizes_array(self, sizes: tuple) -> np.ndarray:
        """A new float32 array of ``sizes`` (one parameter: the template copied and set)."""
        if len(sizes) == 1:
            array = self._zero_sizes.copy()
            array[0] = sizes[0]
            return array
        return np.array(sizes, np.float32)

    def _flags_array(self, flags: tuple) -> np.ndarray:
        """A new int8 array of ``flags``, copied from a template kept per flag pattern."""
        template = self._flag_arrays.get(flags)
        if template is None:
            template = np.array(flags, np.int8)
            if len(self._flag_arrays) < _FLAG_PATTERNS_KEPT:
                self._flag_arrays[flags] = template
        return template.copy()

    def monitor(self, process: NSProcess) -> dict:
        """The monitor's observation of the process's last transition (a null action before it)."""
        reward = self._zero_clock.copy()
        reward[0] = process.last_reward
        clock = self._zero_clock.copy()
        clock[0] = process.t
        action = self._null_action if process.last_action is None else process.last_action
        if type(action) is np.ndarray:  # the agent's own array, or our template: a copy
            action = self._in_bounds(action)
        return {
            "last_state": self._observe(process.last_state),
            "last_action": action,
            "last_reward": reward,
            "state": self._observe(process.state),
            "relative_time": clock,
        }


_FLAG_PATTERNS_KEPT = 64
"""Flag patterns whose arrays a builder keeps (changes usually repeat a few patterns)."""
_CLOCK = spaces.Box(0.0, np.inf, (1,), np.float32)


class _BoundedCopy:
    """Gives a new copy of a Box action, clipped into the space (a class: envs are pickled).

    The dynamics clip an out-of-bounds action (as Gymnasium's do) while the reward sees it as
    given; an observation shows the action clipped, so it stays inside its declared space.
    """

    def __init__(self, space: spaces.Space[Any]) -> None:
        box: Any = space if isinstance(space, spaces.Box) else None
        self._low = None if box is None else box.low
        self._high = None if box is None else box.high
        self._scalar = box is not None and box.shape == (1,)
        if self._scalar:
            self._lo, self._hi = float(box.low[0]), float(box.high[0])

    def __call__(self, action: np.ndarray) -> np.ndarray:
        if self._low is None:
            return action.copy()
        if self._scalar and self._lo <= action.item() <= self._hi:
            return action.copy()
        return np.clip(action, self._low, self._high)


def _null_element(space: spaces.Space[Any]) -> Any:
    if isinstance(space, spaces.Discrete):
        return int(space.start)
    if isinstance(space, spaces.Box):
        return np.clip(np.zeros(space.shape, space.dtype), space.low, space.high)
    raise TypeError(f"unsupported action space {space}")
