"""Adapters that let any policy drive a seat of the game: a function, an SB3 model, an ns_pz agent.

A seat (nature, monitor, decision agent) can be played by

* a callable ``observation -> action``;
* an object with Stable-Baselines3's ``predict(observation, deterministic=...)`` (any SB3 model
  or policy, and anything shaped like one), asked deterministically unless told otherwise;
* an :class:`ns_pz.agents.base.Agent`-shaped object (``act(observation, model)``,
  ``reset(rng)``, ``needs_model``), which is handed the planning model the notification level
  allows, like in every other ns_pz loop.

:func:`decision_policy` wraps any of them as a function of the process, which is what
:meth:`ns_pz.process.NSProcess.play_until` calls on the agent's turns.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


def call_policy(policy: Any, observation: Any, *, deterministic: bool = True) -> Any:
    """The action of ``policy`` (a callable or an SB3-style model) for ``observation``."""
    predict = getattr(policy, "predict", None)
    if callable(predict):
        action, _ = predict(observation, deterministic=deterministic)
        return action
    return policy(observation)


def check_policy(policy: Any, seat: str) -> None:
    """Raise ``TypeError`` unless ``policy`` can drive ``seat``.

    Raises:
        TypeError: ``policy`` is neither callable, nor has ``predict``, nor (for the agent's
            seat) ``act``.
    """
    if callable(getattr(policy, "predict", None)) or callable(policy):
        return
    if seat == "agent" and callable(getattr(policy, "act", None)):
        return
    allowed = "a callable obs -> action or an object with SB3's predict()"
    if seat == "agent":
        allowed += " or an ns_pz Agent (act(obs, model))"
    raise TypeError(f"policies[{seat!r}]={policy!r} cannot drive the {seat} seat; give {allowed}")


class DecisionPolicy:
    """Plays the decision agent's seat of a process with any supported policy.

    Args:
        policy: A callable, an SB3-style model or an ns_pz ``Agent``.
        deterministic: Passed to ``predict`` of an SB3-style model.
    """

    def __init__(self, policy: Any, *, deterministic: bool = True) -> None:
        check_policy(policy, "agent")
        self.policy = policy
        self.deterministic = deterministic
        self._agent = callable(getattr(policy, "act", None)) and not callable(
            getattr(policy, "predict", None)
        )

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode (an ns_pz agent gets ``rng``; other policies carry no episode state)."""
        if self._agent:
            self.policy.reset(rng)

    def __call__(self, process: NSProcess) -> Any:
        """The action for the agent's observation of ``process`` now."""
        observation = process.agent_observation()
        if self._agent:
            needs_model = getattr(self.policy, "needs_model", True)
            model = process.planning_model() if needs_model else None
            return self.policy.act(observation, model)
        return call_policy(self.policy, observation, deterministic=self.deterministic)


DecideFn = Callable[["NSProcess"], Any]
