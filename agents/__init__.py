"""Decision agents (installed as ``ns_pz.agents``)."""

from ns_pz.agents.base import Agent
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.evaluation import Episode, evaluate, mean_and_standard_error, run_episode
from ns_pz.agents.planners import RandomShooting, SnapshotValueIteration, value_iteration

__all__ = [
    "Agent",
    "Episode",
    "RandomAgent",
    "RandomShooting",
    "SnapshotValueIteration",
    "evaluate",
    "mean_and_standard_error",
    "run_episode",
    "value_iteration",
]
