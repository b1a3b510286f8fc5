"""A monitor played by any policy over the monitor's observation (a learned detector)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ns_pz.checks import flag
from ns_pz.family import EnvFamily
from ns_pz.monitor.features import MonitorFeatures
from ns_pz.monitor.monitors import Flags, Monitor, Sizes, as_flags
from ns_pz.observations import monitor_flags_space, monitor_observation_space
from ns_pz.params import Params
from ns_pz.seat_policies import (
    RecurrentMemory,
    call_policy,
    call_recurrent_policy,
    check_policy,
    check_policy_spaces,
    is_recurrent,
)


class PolicyMonitorMemory(RecurrentMemory):
    """One episode's memory of a :class:`PolicyMonitor`: its features' and its policy's."""

    __slots__ = ("features",)

    def __init__(self, features: Any) -> None:
        super().__init__()
        self.features = features
        """The :class:`~ns_pz.monitor.MonitorFeatures` memory (``None`` without features)."""


class PolicyMonitor(Monitor):
    """The monitor's seat played by a policy that raises flags, as a learner in that seat does.

    The policy maps the monitor observation (:func:`ns_pz.observations.monitor_observation_space`)
    to one 0/1 flag per parameter (``MultiDiscrete([2] * n)``); it reports no change sizes, so
    at ``detailed`` the agent hears flags with zero sizes.

    Args:
        policy: A callable ``obs -> flags`` or an SB3-style model.
        deterministic: Passed to ``predict``; sampling (``False``) draws from the monitor's
            generator, so one seed reproduces it.
        features: The :class:`~ns_pz.monitor.MonitorFeatures` the policy was trained with (its
            observation then holds the clock and the evidence since its last alarm).
        recurrent: The policy is a recurrent SB3-style model (sb3-contrib's ``RecurrentPPO``):
            its hidden state is kept per episode and handed back at every turn, as in training.

    Raises:
        TypeError: ``policy`` cannot act, ``deterministic`` or ``recurrent`` is not a bool,
            ``features`` is not ``None`` or a :class:`~ns_pz.monitor.MonitorFeatures`, or
            ``recurrent=True`` for a policy without ``predict``.
    """

    def __init__(
        self,
        policy: Any,
        *,
        deterministic: bool = True,
        features: MonitorFeatures | None = None,
        recurrent: bool = False,
    ) -> None:
        check_policy(policy, "monitor", "PolicyMonitor(policy)")
        if features is not None and not isinstance(features, MonitorFeatures):
            raise TypeError(f"features={features!r} must be None or a MonitorFeatures")
        self.recurrent = flag("recurrent", recurrent)
        if recurrent and not callable(getattr(policy, "predict", None)):
            raise TypeError(
                f"recurrent=True needs a model with predict(obs, state, episode_start); "
                f"{policy!r} has no predict"
            )
        if not recurrent and is_recurrent(policy):
            raise ValueError(
                f"{policy!r} is a recurrent model: give PolicyMonitor(model, recurrent=True), "
                "so that its state is carried from one turn to the next (without it, every "
                "turn starts afresh)"
            )
        self.policy = policy
        self.deterministic = flag("deterministic", deterministic)
        self.features = features
        self._count = 0
        self._family: EnvFamily | None = None

    def bind(self, family: EnvFamily, theta0: Params) -> None:
        """Learn the number of parameters (one flag each).

        One instance serves any number of environments of one family (a vector of envs, the
        game and its view), whatever their θ_0; as with the detectors, binding it to another
        family is refused, since it would change the flag count under the environments already
        using it.

        Raises:
            ValueError: The policy's own spaces (an SB3 model's) are not the monitor seat's for
                ``family``, or it is bound to another family already.
        """
        if self._family is not None and repr(family) != repr(self._family):
            raise ValueError(
                f"PolicyMonitor is bound to {self._family!r}; give {family!r} its own "
                "PolicyMonitor instance"
            )
        if self.features is not None:
            self.features.bind(family, theta0)
        if self._family is not None:
            return
        check_policy_spaces(
            self.policy,
            monitor_observation_space(family, self.features),
            monitor_flags_space(family.params_cls),
            "PolicyMonitor's policy",
            " (was it trained on another environment?)",
        )
        self._count = len(family.params_cls.names())
        self._family = family

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: Any,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """The policy's flags for ``observation``; sizes zero.

        Raises:
            ValueError: The policy's answer is not one 0/1 flag per parameter.
        """
        seen: Any = observation
        if self.features is not None:
            self.features.update(memory.features, observation)  # type: ignore[arg-type]
            seen = self.features.observation(observation, memory.features)  # type: ignore[arg-type]
        if self.recurrent:
            answer = call_recurrent_policy(
                self.policy, seen, memory, deterministic=self.deterministic, rng=rng
            )
        else:
            answer = call_policy(self.policy, seen, deterministic=self.deterministic, rng=rng)
        flags = as_flags(answer, self._count)
        if flags is None:
            raise ValueError(
                f"the monitor policy answered {answer!r}; it must give {self._count} flags of 0/1"
            )
        if self.features is not None:
            self.features.alarmed(memory.features, flags)
        return flags, (0.0,) * self._count

    def initial_memory(self) -> PolicyMonitorMemory:
        """The features' running statistics and the policy's state, at an episode's start."""
        features = None if self.features is None else self.features.initial_memory()
        return PolicyMonitorMemory(features)

    def episode_memory(self, theta0: Params) -> PolicyMonitorMemory:
        """:meth:`initial_memory` for an episode from ``theta0`` (``reset`` options).

        Raises:
            ValueError: The features' evidence or detector is bound to another θ_0
                (:meth:`MonitorFeatures.episode_memory`).
        """
        features = None if self.features is None else self.features.episode_memory(theta0)
        return PolicyMonitorMemory(features)

    def __repr__(self) -> str:
        return f"PolicyMonitor({self.policy!r})"
