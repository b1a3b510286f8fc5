"""Notification and planning
=========================

How much does being told help? A planner that solves the MDP it believes in
(:class:`ns_pz.agents.SnapshotValueIteration`) plays FrozenLake while the ice changes once:
the probability that a move goes where it was meant to drops from 0.7 to 0.4 after the first
decision epoch. The notification level decides what the planner believes.
"""

# %%
# The change and the three levels
# -------------------------------

import matplotlib.pyplot as plt
from ns_pz.agents import SnapshotValueIteration, evaluate, mean_and_standard_error

import ns_pz
from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

nature = ScriptedNature(
    {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [(0.4, 0.3, 0.3)])}
)


def make_env(level: str) -> ns_pz.NSGymEnv:
    """FrozenLake with the single change, at one notification level."""
    return ns_pz.make_gym(
        "ns_pz/FrozenLake-v0",
        params={"slip": (0.7, 0.15, 0.15)},
        nature=nature,
        notification=level,
    )


# %%
# What the agent sees and what its planning model assumes, step by step. The change fires at
# step 1, drives transition 1, and is reported in the observation after it.

for level in ("none", "basic", "detailed"):
    env = make_env(level)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, *_ = env.step(1)
        print(
            f"{level:8s} t={int(obs['relative_time'][0])} env_change={obs['env_change']} "
            f"delta_change={obs['delta_change']} planner's slip={env.planning_model().theta.slip}"
        )

# %%
# Success rates over 100 seeded episodes per level. With notification the planner re-plans
# under the new slip; without it, it keeps planning for ice that no longer exists.

levels = ("none", "basic", "detailed")
results = {}
for level in levels:
    episodes = evaluate(
        lambda level=level: make_env(level), SnapshotValueIteration(gamma=0.99), range(100)
    )
    results[level] = mean_and_standard_error([e.episode_return for e in episodes])
    print(f"notification={level:8s} success rate {results[level][0]:.2f} ± {results[level][1]:.2f}")

fig, ax = plt.subplots(figsize=(5, 3))
ax.bar(levels, [results[lv][0] for lv in levels], yerr=[results[lv][1] for lv in levels], capsize=4)
ax.set_ylabel("success rate (mean ± SE)")
ax.set_title("Snapshot value iteration after a change")
fig.tight_layout()

# %%
# ``basic`` tells the agent *that* something changed but not how, so a planner that only reads
# θ from its model cannot use it: it plans with θ_0 and does exactly as well as at ``none``.
