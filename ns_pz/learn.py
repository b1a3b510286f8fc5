"""Training any seat with Stable-Baselines3 (the names of :mod:`ns_pz.learning`, kept here).

New code imports from :mod:`ns_pz.learning`; this module keeps earlier imports working.
Needs the ``learn`` extra.
"""

from ns_pz.learning.alternating import PopulationNature, RarlResult, RoundLog, rarl
from ns_pz.learning.rollouts import episode_returns, mean_and_se
from ns_pz.learning.training import (
    AdversaryTrials,
    TrainArgs,
    make_model,
    make_seat_env,
    train,
    train_adversaries,
    train_adversary,
)

__all__ = [
    "AdversaryTrials",
    "PopulationNature",
    "RarlResult",
    "RoundLog",
    "TrainArgs",
    "episode_returns",
    "make_model",
    "make_seat_env",
    "mean_and_se",
    "rarl",
    "train",
    "train_adversaries",
    "train_adversary",
]
