"""Adapters that let any policy drive a seat of the game: a function, an SB3 model, an ns_pz agent.

A seat (nature, monitor, decision agent) can be played by

* a callable ``observation -> action``;
* an object with Stable-Baselines3's ``predict(observation, deterministic=...)`` (any SB3 model
  or policy, and anything shaped like one), asked deterministically unless told otherwise; asked
  stochastically, it samples from torch's generator reseeded from the seat's own generator for
  that one call (torch's global state is restored after it), so one seed reproduces the run;
* an :class:`ns_pz.agents.base.Agent`-shaped object (``act(observation, model)``,
  ``reset(rng)``, ``needs_model``), which is handed the planning model the notification level
  allows, like in every other ns_pz loop.

:func:`decision_policy` wraps any of them as a function of the process, which is what
:meth:`ns_pz.process.NSProcess.play_until` calls on the agent's turns.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from ns_pz.checks import flag

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


def call_policy(
    policy: Any,
    observation: Any,
    *,
    deterministic: bool = True,
    rng: np.random.Generator | None = None,
) -> Any:
    """The action of ``policy`` (a callable or an SB3-style model) for ``observation``.

    Asked with ``deterministic=False`` and given ``rng``, an SB3-style model samples from torch's
    generator (the CPU's, or its CUDA device's) seeded from ``rng`` (one draw per call) inside
    ``torch.random.fork_rng``: the sample is reproducible and those generators are restored
    afterwards. The generator is torch's global one, borrowed for the call: do not sample two
    seats in two threads at once.
    """
    predict = getattr(policy, "predict", None)
    if not callable(predict):
        return policy(observation)
    action, _ = _predict(predict, policy, observation, deterministic, rng)
    return action


class RecurrentMemory:
    """A recurrent policy's memory within one episode: a fresh one at each episode's start."""

    __slots__ = ("state", "episode_start")

    def __init__(self) -> None:
        self.state: Any = None
        """The policy's hidden state, as its ``predict`` last returned it."""
        self.episode_start = True
        """Whether the policy has not acted yet this episode."""


def call_recurrent_policy(
    policy: Any,
    observation: Any,
    memory: RecurrentMemory,
    *,
    deterministic: bool = True,
    rng: np.random.Generator | None = None,
) -> Any:
    """A recurrent SB3-style model's action (sb3-contrib's ``RecurrentPPO``), ``memory`` carried.

    ``predict`` is handed the state it returned last and whether the episode starts (the
    model then resets its state); ``memory`` keeps what it returns for the next turn.

    Args:
        policy: A model whose ``predict`` takes ``state`` and ``episode_start``.
        observation: This turn's observation.
        memory: This episode's memory of the policy (:class:`RecurrentMemory`).
        deterministic: As in :func:`call_policy`, as is ``rng`` (sampling reproducibly).
        rng: As in :func:`call_policy`.
    """
    start = np.array([memory.episode_start], dtype=bool)
    action, memory.state = _predict(
        policy.predict,
        policy,
        observation,
        deterministic,
        rng,
        state=memory.state,
        episode_start=start,
    )
    memory.episode_start = False
    return action


def _predict(
    predict: Any,
    policy: Any,
    observation: Any,
    deterministic: bool,
    rng: np.random.Generator | None,
    **extra: Any,
) -> tuple[Any, Any]:
    """``predict(observation, deterministic=..., **extra)``, sampling from a seeded torch RNG."""
    torch = sys.modules.get("torch")  # loaded if the model is a torch one; never imported here
    if deterministic or rng is None or torch is None:
        return predict(observation, deterministic=deterministic, **extra)
    seed = int(rng.integers(2**63))
    device: Any = getattr(policy, "device", None)  # an SB3 model's; sampling draws on it
    cuda = [device.index or 0] if getattr(device, "type", None) == "cuda" else []
    with torch.random.fork_rng(devices=cuda):  # restores exactly the generators seeded below
        torch.random.default_generator.manual_seed(seed)
        if cuda:
            with torch.cuda.device(cuda[0]):
                torch.cuda.manual_seed(seed)
        return predict(observation, deterministic=False, **extra)


def check_policy(policy: Any, seat: str, label: str | None = None) -> None:
    """Raise ``TypeError`` unless ``policy`` can drive ``seat``.

    Args:
        policy: The candidate.
        seat: ``"agent"``, ``"nature"`` or ``"monitor"``.
        label: How the error names the argument (default ``policies[seat]``).

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
    label = label or f"policies[{seat!r}]"
    raise TypeError(f"{label}={policy!r} cannot drive the {seat} seat; give {allowed}")


def check_policy_spaces(
    policy: Any,
    observation_space: spaces.Space[Any],
    action_space: spaces.Space[Any],
    label: str,
    hint: str = "",
) -> None:
    """Refuse a policy whose own spaces (an SB3 model's) differ from the seat's.

    Compared when ``policy`` carries ``observation_space`` / ``action_space`` (SB3 models do):
    the kind and shape of each (per key for a ``Dict``) and, for a ``Box`` action, its bounds,
    which tell action conventions apart.

    Raises:
        ValueError: A space differs; the message names both.
    """
    for kind, expected in (("observation", observation_space), ("action", action_space)):
        own = getattr(policy, f"{kind}_space", None)
        if not isinstance(own, spaces.Space):
            continue
        same = _same_layout(own, expected)
        if same and kind == "action" and isinstance(own, spaces.Box):
            box: Any = expected  # a Box too, by _same_layout
            same = np.array_equal(own.low, box.low) and np.array_equal(own.high, box.high)
        if not same:
            raise ValueError(
                f"{label} acts in the {kind} space {own}, but this seat's is {expected}{hint}"
            )


def _same_layout(own: spaces.Space[Any], expected: spaces.Space[Any]) -> bool:
    if type(own) is not type(expected):
        return False
    if isinstance(own, spaces.Dict):
        return own.keys() == expected.keys() and all(  # type: ignore[attr-defined]
            _same_layout(own[key], expected[key])  # type: ignore[index]
            for key in own.keys()
        )
    return own.shape == expected.shape


def is_recurrent(policy: Any) -> bool:
    """Whether ``policy`` is a recurrent SB3-style model (sb3-contrib's ``RecurrentPPO``).

    Such a model's ``predict`` must be handed the state it returned last and whether an episode
    starts (:func:`call_recurrent_policy`); asked without them it starts from a fresh state at
    every call, a different policy. Recognised by the LSTM state shape sb3-contrib's recurrent
    policies carry, on the model's ``policy`` or on the policy given itself.
    """
    for candidate in (getattr(policy, "policy", None), policy):
        if isinstance(getattr(candidate, "lstm_hidden_state_shape", None), tuple):
            return True
    return False


def is_agent(policy: Any) -> bool:
    """Whether ``policy`` is an ns_pz ``Agent`` (``act(obs, model)``, no SB3 ``predict``)."""
    return callable(getattr(policy, "act", None)) and not callable(getattr(policy, "predict", None))


class DecisionPolicy:
    """Plays the decision agent's seat of a process with any supported policy.

    Args:
        policy: A callable, an SB3-style model or an ns_pz ``Agent``.
        deterministic: Passed to ``predict`` of an SB3-style model.

    Raises:
        TypeError: ``policy`` cannot drive the agent's seat, or ``deterministic`` is not a bool.
    """

    def __init__(self, policy: Any, *, deterministic: bool = True) -> None:
        check_policy(policy, "agent")
        self.policy = policy
        self.deterministic = flag("deterministic", deterministic)
        self._agent = is_agent(policy)
        self._recurrent = is_recurrent(policy)
        self._rng: np.random.Generator | None = None
        self._memory = RecurrentMemory()

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: ``rng`` drives an ns_pz agent, or an SB3 model's sampling.

        A recurrent model (:func:`is_recurrent`) starts the episode from a fresh state and
        carries its state from one step to the next within it.
        """
        self._rng = rng
        self._memory = RecurrentMemory()
        if self._agent:
            self.policy.reset(rng)

    def __call__(self, process: NSProcess) -> Any:
        """The action for the agent's observation of ``process`` now."""
        observation = process.agent_observation()
        if self._agent:
            needs_model = getattr(self.policy, "needs_model", True)
            model = process.planning_model() if needs_model else None
            return self.policy.act(observation, model)
        if self._recurrent:
            return call_recurrent_policy(
                self.policy,
                observation,
                self._memory,
                deterministic=self.deterministic,
                rng=self._rng,
            )
        return call_policy(
            self.policy, observation, deterministic=self.deterministic, rng=self._rng
        )
