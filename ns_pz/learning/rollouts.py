"""Playing whole episodes with a policy in any seat's environment, and scoring them.

Needs no torch: a trained SB3 model is only asked for actions.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Mapping
from typing import Any

import gymnasium as gym

from ns_pz.seat_policies import (
    DecisionPolicy,
    RecurrentMemory,
    call_policy,
    call_recurrent_policy,
    check_policy,
    is_agent,
    is_recurrent,
)
from ns_pz.views import NSGymEnv


def episode_returns(
    env: gym.Env,
    policy: Any,
    seeds: Iterable[int],
    options: Mapping[str, Any] | None = None,
) -> list[float]:
    """The learner's return in ``env``, one episode per seed, ``policy`` deterministic.

    ``policy`` is a callable ``obs -> action``, an SB3-style model or, in an agent's view
    (:func:`ns_pz.single_agent` with ``learner="agent"``), an ns_pz ``Agent``, which is handed
    the planning model the notification level allows and a generator from the seed. A
    recurrent model (sb3-contrib's ``RecurrentPPO``) carries its state through each episode.
    ``options`` are passed to every ``reset`` (``{"params": θ_0}`` starts each episode from
    that θ_0, which a domain-randomising nature then does not redraw).

    Raises:
        TypeError: ``policy`` cannot act, or is an ns_pz ``Agent`` outside an agent's view.
    """
    view: Any = env.unwrapped
    decide = None
    if is_agent(policy):
        if not isinstance(view, NSGymEnv):
            raise TypeError(
                f"policy={policy!r} is an ns_pz Agent, which plays the decision agent's seat "
                f"only; {env!r} is not an agent's view"
            )
        decide = DecisionPolicy(policy)
    else:
        seat = "agent" if isinstance(view, NSGymEnv) else getattr(view, "learner", "learner's")
        check_policy(policy, seat, "policy")
    recurrent = decide is None and is_recurrent(policy)
    returns = []
    for seed in seeds:
        observation, _ = env.reset(seed=seed, options=None if options is None else dict(options))
        if decide is not None:
            decide.reset(view.process.seat_rng())
        total, done, memory = 0.0, False, RecurrentMemory()
        while not done:
            if decide is not None:
                action = decide(view.process)
            elif recurrent:
                action = call_recurrent_policy(policy, observation, memory)
            else:
                action = call_policy(policy, observation, deterministic=True)
            observation, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return returns


def mean_and_se(values: list[float]) -> tuple[float, float]:
    """Mean and standard error (ddof=1; 0 for one value)."""
    mean = statistics.fmean(values)
    se = statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
    return mean, se
