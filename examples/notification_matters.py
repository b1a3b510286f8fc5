"""How much does being told help? A value-iteration planner on FrozenLake after a single change.

The slip probability drops from 0.7 to 0.4 after the first decision epoch. Without notification
the planner keeps planning with θ_0; with detailed notification its planning model holds the
new θ.
"""

from ns_pz.agents import SnapshotValueIteration, evaluate, mean_and_standard_error

import ns_pz
from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

nature = ScriptedNature(
    {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [(0.4, 0.3, 0.3)])}
)
for level in ("none", "basic", "detailed"):

    def make_env(level=level):
        """A fresh environment at this notification level."""
        return ns_pz.make_gym(
            "ns_pz/FrozenLake-v0",
            params={"slip": (0.7, 0.15, 0.15)},
            nature=nature,
            notification=level,
        )

    episodes = evaluate(make_env, SnapshotValueIteration(gamma=0.99), range(200))
    mean, error = mean_and_standard_error([e.episode_return for e in episodes])
    print(f"notification={level:8s} success rate {mean:.3f} ± {error:.3f}")
