"""Learning in the game: any seat as a Gymnasium env, training, robust RL and its evaluation.

Read the modules in this order:

1. :mod:`~ns_pz.learning.seats` — :func:`single_agent`: the game seen from one seat (nature,
   monitor or agent) as a Gymnasium env, the other seats played by fixed policies.
2. :mod:`~ns_pz.learning.rollouts` — play episodes with any policy; mean and standard error.
3. :mod:`~ns_pz.learning.statistics` — CVaR, quantiles, the interquartile mean over runs and
   bootstrap intervals.
4. :mod:`~ns_pz.learning.robustness` — :func:`evaluate_robustness`: a policy over a θ grid,
   a suite of natures and freshly trained adversaries.
5. :mod:`~ns_pz.learning.training` — SB3 training of one seat, vectorised; adversaries with
   restarts (``learn`` extra).
6. :mod:`~ns_pz.learning.alternating` — RARL and its population variant (``learn`` extra).
7. :mod:`~ns_pz.learning.sb3_vec` and :mod:`~ns_pz.learning.rllib` — the native vector env as
   an SB3 ``VecEnv``, and the game under RLlib.

How a policy plays a seat (:mod:`ns_pz.seat_policies`) and nature's payoffs
(:mod:`ns_pz.regret`) stay beside the game, which uses them. Domain randomisation is a nature
(:class:`ns_pz.nature.DomainRandomisation`). The earlier module paths (``ns_pz.seats``,
``ns_pz.learn``, ``ns_pz.sb3_vec``, ``ns_pz.rllib``) still import. Importing this package loads
no torch: the training names load Stable-Baselines3 on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from ns_pz.learning.robustness import (
    AdversarySearch,
    Condition,
    RobustnessReport,
    Summary,
    evaluate_robustness,
)
from ns_pz.learning.rollouts import episode_returns, mean_and_se
from ns_pz.learning.statistics import Estimate, aggregate_runs, cvar, interquartile_mean

_LAZY = {
    "TrainArgs": "training",
    "AdversaryTrials": "training",
    "make_agent_vec_env": "training",
    "make_model": "training",
    "make_seat_env": "training",
    "train": "training",
    "train_adversary": "training",
    "train_adversaries": "training",
    "PopulationNature": "alternating",
    "RarlResult": "alternating",
    "RoundLog": "alternating",
    "rarl": "alternating",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'ns_pz.learning' has no attribute {name!r}")
    return getattr(importlib.import_module(f"ns_pz.learning.{module}"), name)


__all__ = [
    "AdversarySearch",
    "AdversaryTrials",
    "Condition",
    "Estimate",
    "PopulationNature",
    "RarlResult",
    "RobustnessReport",
    "RoundLog",
    "Summary",
    "TrainArgs",
    "aggregate_runs",
    "cvar",
    "episode_returns",
    "evaluate_robustness",
    "interquartile_mean",
    "make_agent_vec_env",
    "make_model",
    "make_seat_env",
    "mean_and_se",
    "rarl",
    "train",
    "train_adversaries",
    "train_adversary",
]
