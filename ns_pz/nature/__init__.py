"""Nature: schedulers (when), update functions (how), policies and constraints."""

from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.policies import Nature, RandomNature, ScriptedNature, StaticNature
from ns_pz.nature.schedulers import (
    ContinuousScheduler,
    DiscreteScheduler,
    PeriodicScheduler,
    RandomScheduler,
    Scheduler,
)
from ns_pz.nature.updates import (
    DecrementUpdate,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionNoUpdate,
    DistributionStepWiseUpdate,
    DistributionUpdateFn,
    IncrementUpdate,
    NoUpdate,
    RandomWalk,
    StepWiseUpdate,
    UpdateFn,
)

__all__ = [
    "ContinuousScheduler",
    "DecrementUpdate",
    "DiscreteScheduler",
    "DistributionDecrementUpdate",
    "DistributionIncrementUpdate",
    "DistributionNoUpdate",
    "DistributionStepWiseUpdate",
    "DistributionUpdateFn",
    "IncrementUpdate",
    "Nature",
    "NatureConstraints",
    "NoUpdate",
    "PeriodicScheduler",
    "RandomNature",
    "RandomScheduler",
    "RandomWalk",
    "Scheduler",
    "ScriptedNature",
    "StaticNature",
    "StepWiseUpdate",
    "UpdateFn",
]
