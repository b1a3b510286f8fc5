"""Monitor policies: what the decision agent is told.

A monitor acts at the start of every step, after nature and before the decision agent. It may
look at the last transition (``last_state``, ``last_action``, ``last_reward``, ``state``,
``relative_time``) and returns a notification: a 0/1 flag and a change size per parameter, in
the parameter set's field order. What the monitor says is about the θ that generated the last
transition; the θ nature has just chosen for the coming transition is never visible to it, so
the agent hears of a change one step after it first acts, at the earliest.

The game then masks the notification to its level (see
:class:`~ns_pz.monitor.notification.NotificationLevel`).
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from ns_pz.family import EnvFamily
from ns_pz.params import Params

Flags = tuple[int, ...]
Sizes = tuple[float, ...]


class Monitor(ABC):
    """Base of every monitor policy.

    Attributes:
        reads_ground_truth: Whether :meth:`notify` receives the true change sizes. Only oracle
            monitors set it; detectors must infer changes from observations.
        needs_observation: Whether :meth:`notify` needs the monitor observation (an oracle does
            not, which spares the Gymnasium view building it every step).
        quiet_without_change: For a monitor that :attr:`reads_ground_truth`: whether it says
            nothing on a transition without a true change, so the process may answer "no
            change" without calling it (the exact oracle). A monitor with memory, delays or
            false alarms sets it to ``False`` and is called at every transition.
    """

    reads_ground_truth: ClassVar[bool] = False
    needs_observation: ClassVar[bool] = True
    quiet_without_change: ClassVar[bool] = True

    def bind(self, family: EnvFamily, theta0: Params) -> None:  # noqa: B027 - optional hook
        """Learn, when an environment is built, what a monitor may know before any data.

        That is the family (spaces, the planning model under θ_0) and θ_0, nothing else.
        """

    def initial_memory(self) -> Any:
        """Fresh per-episode memory (``None`` for a memoryless monitor)."""
        return None

    def believed_theta(self, memory: Any) -> Params | None:
        """θ the monitor believes in force now, from this episode's ``memory``.

        ``None`` (the default) means no belief beyond what the notifications say. A detector
        returns θ_0 updated by the changes it has detected: what an honest planner at
        ``detailed`` may plan with when this monitor, not an oracle, informs it.
        """
        return None

    def told_changes(self, memory: Any) -> Mapping[int, int] | None:
        """For a monitor that :attr:`reads_ground_truth`: what of the truth it has told.

        For each parameter (by index) whose change it has reported, the latest transition whose
        change to it was reported; the planner at ``detailed`` gets θ_0 with those parameters
        at their values of those transitions, and nothing of a change it missed or has not
        reported yet. ``None`` (the default, the exact oracle): everything so far.
        """
        return None

    def episode_memory(self, theta0: Params) -> Any:
        """Fresh memory for an episode that starts from another θ_0 (``reset`` options).

        The default is :meth:`initial_memory`: what a monitor keeps does not depend on θ_0.
        """
        return self.initial_memory()

    def copy_memory(self, memory: Any) -> Any:
        """Memory for a planning copy made now from an episode with ``memory`` (left as it is).

        The copy starts each of its episodes from it too. A monitor that reads the ground
        truth starts afresh (:meth:`initial_memory`): it tells the copy about the copy's own
        changes only, never about the original's still pending or missed ones. Any other
        monitor knows what it knew: a deep copy of ``memory`` (a detector's reference model,
        moved by its alarms; a fresh one would compare the copy's world with θ_0 and report
        changes that never happen there). Monitors whose memory holds the episode's timeline
        override this to keep just what they know, which is cheaper.
        """
        if self.reads_ground_truth:
            return self.initial_memory()
        return copy.deepcopy(memory)

    @abstractmethod
    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: Any,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """Flags and sizes to tell the agent.

        Args:
            observation: The monitor observation (``None`` if not :attr:`needs_observation`).
            truth: True size of each parameter's change at the last transition (0.0 where none),
                only for monitors that :attr:`reads_ground_truth`; otherwise ``None``.
            memory: This episode's memory from :meth:`initial_memory`.
            rng: The monitor's generator, seeded at reset.
        """


class OracleMonitor(Monitor):
    """Reports every true change exactly: flags where a parameter changed, and the sizes."""

    reads_ground_truth = True
    needs_observation = False

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: Any,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """The true change, unaltered."""
        if truth is None:
            raise RuntimeError("OracleMonitor.notify needs the true change sizes (truth=None)")
        return tuple(int(size > 0.0) for size in truth), tuple(truth)

    def __repr__(self) -> str:
        return "OracleMonitor()"


def watched_names(params: Any) -> tuple[str, ...] | None:
    """A detector's ``params`` argument: ``None`` (every parameter) or a non-empty name list.

    Raises:
        TypeError: A bare string (it would read as its letters) or a non-string name.
        ValueError: An empty list.
    """
    if params is None:
        return None
    wanted = f"params={params!r} must be a list of parameter names, e.g. ['slip']"
    if isinstance(params, str):  # it would read as its letters
        raise TypeError(wanted)
    try:
        names = tuple(params)  # once: a generator is consumed by reading it
    except TypeError:
        raise TypeError(wanted) from None
    if not all(isinstance(name, str) for name in names):
        raise TypeError(f"params={list(names)!r} must be a list of parameter names")
    if not names:
        raise ValueError("params=[] watches nothing; give at least one name, or None for all")
    return names


class Detector(Monitor):
    """Base of the honest detectors: bound to one family and θ_0, which they may know.

    A detector builds its reference model in :meth:`bind` and keeps every episode's state in
    its memory, so one instance serves any number of environments of the same family and θ_0
    (a vector of envs, the game and its view). Binding it to another family or θ_0 raises: its
    reference would silently change under the environments already using it.
    """

    _family: EnvFamily | None = None
    _theta0: Params | None = None

    def _already_bound(self, family: EnvFamily, theta0: Params) -> bool:
        """Whether ``bind`` has nothing to do (bound to the same family and θ_0 already).

        Raises:
            ValueError: Bound to another family or θ_0.
        """
        if self._family is None:
            return False
        if repr(family) == repr(self._family) and theta0 == self._theta0:
            return True
        raise ValueError(
            f"{type(self).__name__} is bound to {self._family!r} with θ_0 = {self._theta0!r}; "
            f"give {family!r} with θ_0 = {theta0!r} its own instance"
        )

    def episode_memory(self, theta0: Params) -> Any:
        """Memory for an episode from ``theta0``: refused unless it is the bound θ_0.

        A detector whose reference model is built for the bound θ_0 cannot serve another;
        one whose reference is just a θ in its memory overrides this to start from ``theta0``.

        Raises:
            ValueError: ``theta0`` is not the θ_0 it is bound to.
        """
        if self._theta0 is not None and theta0 != self._theta0:
            raise ValueError(
                f"{type(self).__name__} is bound to θ_0 = {self._theta0!r}, but this episode "
                f"starts from θ_0 = {theta0!r} (reset options): its reference model would be "
                "wrong. Build the environment with params= that θ_0 and a detector of its own"
            )
        return self.initial_memory()

    def _bound_theta0(self) -> Params:
        """θ_0 of the bound environment.

        Raises:
            RuntimeError: Not bound yet.
        """
        if self._theta0 is None:
            raise RuntimeError(
                f"{type(self).__name__} is not bound to an environment; pass it as monitor= to "
                "an ns_pz environment (which calls bind(family, theta0))"
            )
        return self._theta0


def has_transition(observation: dict[str, Any] | None) -> bool:
    """Whether a monitor observation holds a transition (it does not at reset, ``t = 0``).

    At reset ``last_action`` is the action space's null element and ``last_state`` equals
    ``state``; that is no evidence about θ, and a detector must treat it as no data.
    """
    return observation is not None and float(observation["relative_time"][0]) > 0.0


def silence(count: int) -> tuple[Flags, Sizes]:
    """The notification "no change" for ``count`` parameters."""
    return (0,) * count, (0.0,) * count


def as_flags(value: Any, count: int, kinds: str = "iubfO") -> Flags | None:
    """``value`` as ``count`` flags (Python ints, each 0 or 1), or ``None`` if it is not that.

    ``kinds``: the NumPy dtype kinds accepted (default: integers, bools, and floats or Python
    objects equal to 0 or 1; never complex numbers). Checked on a list of Python numbers:
    ``np.isin`` took 16 µs for six flags.
    """
    array = np.asarray(value)
    if array.shape != (count,) or array.dtype.kind not in kinds:
        return None
    values = array.tolist()
    if not set(values) <= {0, 1}:  # True, 1.0 and 1 are all 1; NaN is none of them
        return None
    return tuple(map(int, values))
