"""ns_pz: non-stationary MDPs as a game of nature, monitor and decision agent.

Importing ``ns_pz`` registers its environments with Gymnasium::

    import gymnasium as gym
    import ns_pz
    from ns_pz.nature import ContinuousScheduler, IncrementUpdate, ScriptedNature

    nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=1), k=0.1)})
    env = gym.make("ns_pz/CartPole-v0", nature=nature, notification="detailed")
    game = ns_pz.make("ns_pz/CartPole-v0", nature=nature)  # the PettingZoo AEC game
"""

# First: in a source checkout, importing it maps ns_pz.envs to envs/ and ns_pz.agents to agents/.
from ns_pz import _source_tree  # noqa: F401
from ns_pz.errors import (
    NSPZError,
    ParamError,
    ParamOutOfRange,
    ResetNeeded,
    UnknownEnvironment,
    UnknownParam,
)
from ns_pz.game import DECISION, MONITOR, NATURE, NSGame
from ns_pz.monitor import Monitor, NotificationLevel, OracleMonitor
from ns_pz.params import Params, ParamSpec, scalar, simplex
from ns_pz.process import GroundTruth
from ns_pz.vector import NSVectorEnv
from ns_pz.views import NSGymEnv

from ns_pz.envs.registry import make, make_gym, make_vec, register, registered_envs, spec  # isort: skip
from ns_pz.learning.seats import single_agent  # isort: skip
from ns_pz.learning.robustness import evaluate_robustness  # isort: skip

__version__ = "0.1.0"

__all__ = [
    "DECISION",
    "MONITOR",
    "NATURE",
    "GroundTruth",
    "Monitor",
    "NSGame",
    "NSGymEnv",
    "NSVectorEnv",
    "NSPZError",
    "NotificationLevel",
    "OracleMonitor",
    "ParamError",
    "ParamOutOfRange",
    "ParamSpec",
    "Params",
    "ResetNeeded",
    "UnknownEnvironment",
    "UnknownParam",
    "evaluate_robustness",
    "make",
    "make_gym",
    "make_vec",
    "register",
    "registered_envs",
    "scalar",
    "simplex",
    "single_agent",
    "spec",
]
