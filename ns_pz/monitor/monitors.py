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

from abc import ABC, abstractmethod
from collections.abc import Sequence
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
    """

    reads_ground_truth: ClassVar[bool] = False
    needs_observation: ClassVar[bool] = True

    def bind(self, family: EnvFamily, theta0: Params) -> None:  # noqa: B027 - optional hook
        """Learn, when an environment is built, what a monitor may know before any data.

        That is the family (spaces, the planning model under θ_0) and θ_0, nothing else.
        """

    def initial_memory(self) -> Any:
        """Fresh per-episode memory (``None`` for a memoryless monitor)."""
        return None

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
