"""Nature: schedulers (when), update functions (how), policies and constraints.

The schedule vocabulary covers all of NS-Gym 1.0.12's, under the same class and argument names
(see :mod:`ns_pz.compat` for NS-Gym's calling conventions and defaults).
"""

from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.distribution_updates import (
    BudgetBoundedIncrement,
    DistributionCyclicUpdate,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionLinearInterpolation,
    DistributionNoUpdate,
    DistributionStepWiseUpdate,
    LipschitzBoundedDistributionUpdate,
    RandomCategorical,
    TargetReversion,
    UniformDrift,
)
from ns_pz.nature.interface import NatureInterface
from ns_pz.nature.learned import PolicyNature
from ns_pz.nature.policies import (
    Nature,
    RandomNature,
    ScriptedNature,
    StaticNature,
    TrajectoryNature,
)
from ns_pz.nature.scalar_updates import (
    BoundedRandomWalk,
    CyclicUpdate,
    DecrementUpdate,
    DeterministicTrend,
    ExponentialDecay,
    GeometricProgression,
    IncrementUpdate,
    LinearInterpolation,
    NoUpdate,
    OrnsteinUhlenbeck,
    OscillatingUpdate,
    PolynomialTrend,
    RandomWalk,
    RandomWalkWithDrift,
    RandomWalkWithDriftAndTrend,
    SigmoidTransition,
    StepWiseUpdate,
)
from ns_pz.nature.schedulers import (
    BurstScheduler,
    ContinuousScheduler,
    CustomScheduler,
    DecayingProbabilityScheduler,
    DiscreteScheduler,
    MemorylessScheduler,
    PeriodicScheduler,
    RandomScheduler,
    Scheduler,
    WindowScheduler,
)
from ns_pz.nature.updates import DistributionUpdateFn, UpdateFn

SCHEDULERS = (
    BurstScheduler,
    ContinuousScheduler,
    CustomScheduler,
    DecayingProbabilityScheduler,
    DiscreteScheduler,
    MemorylessScheduler,
    PeriodicScheduler,
    RandomScheduler,
    WindowScheduler,
)
"""Every scheduler class."""

SCALAR_UPDATES = (
    BoundedRandomWalk,
    CyclicUpdate,
    DecrementUpdate,
    DeterministicTrend,
    ExponentialDecay,
    GeometricProgression,
    IncrementUpdate,
    LinearInterpolation,
    NoUpdate,
    OrnsteinUhlenbeck,
    OscillatingUpdate,
    PolynomialTrend,
    RandomWalk,
    RandomWalkWithDrift,
    RandomWalkWithDriftAndTrend,
    SigmoidTransition,
    StepWiseUpdate,
)
"""Every update function for scalar parameters."""

DISTRIBUTION_UPDATES = (
    BudgetBoundedIncrement,
    DistributionCyclicUpdate,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionLinearInterpolation,
    DistributionNoUpdate,
    DistributionStepWiseUpdate,
    LipschitzBoundedDistributionUpdate,
    RandomCategorical,
    TargetReversion,
    UniformDrift,
)
"""Every update function for probability-vector parameters."""

__all__ = [
    "BoundedRandomWalk",
    "BudgetBoundedIncrement",
    "BurstScheduler",
    "ContinuousScheduler",
    "CustomScheduler",
    "CyclicUpdate",
    "DISTRIBUTION_UPDATES",
    "DecayingProbabilityScheduler",
    "DecrementUpdate",
    "DeterministicTrend",
    "DiscreteScheduler",
    "DistributionCyclicUpdate",
    "DistributionDecrementUpdate",
    "DistributionIncrementUpdate",
    "DistributionLinearInterpolation",
    "DistributionNoUpdate",
    "DistributionStepWiseUpdate",
    "DistributionUpdateFn",
    "ExponentialDecay",
    "GeometricProgression",
    "IncrementUpdate",
    "LinearInterpolation",
    "LipschitzBoundedDistributionUpdate",
    "MemorylessScheduler",
    "Nature",
    "NatureConstraints",
    "NatureInterface",
    "NoUpdate",
    "OrnsteinUhlenbeck",
    "OscillatingUpdate",
    "PeriodicScheduler",
    "PolicyNature",
    "PolynomialTrend",
    "RandomCategorical",
    "RandomNature",
    "RandomScheduler",
    "RandomWalk",
    "RandomWalkWithDrift",
    "RandomWalkWithDriftAndTrend",
    "SCALAR_UPDATES",
    "SCHEDULERS",
    "Scheduler",
    "ScriptedNature",
    "SigmoidTransition",
    "StaticNature",
    "StepWiseUpdate",
    "TargetReversion",
    "TrajectoryNature",
    "UniformDrift",
    "UpdateFn",
    "WindowScheduler",
]
