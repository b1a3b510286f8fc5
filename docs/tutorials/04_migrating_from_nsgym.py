"""Migrating from NS-Gym
=====================

``ns_pz.compat`` is NS-Gym's API running on the ns_pz core: replace ``ns_gym`` with
``ns_pz.compat`` in the imports and NS-Gym code runs, with NS-Gym's names, arguments and
``sched(t)`` / ``fn(param, t)`` conventions. This page runs an NS-Gym-style experiment through
``ns_pz.compat``, writes the same experiment natively, and checks that both produce the same
parameter trajectory. The differences (random schedules follow ``reset(seed=...)``, invalid
vectors refused, environment settings honoured or refused by name) are listed in the
:mod:`ns_pz.compat` docstring.
"""

# %%
# NS-Gym code, package name changed
# ---------------------------------
#
# FrozenLake whose intended-move probability drops by 0.1 every second step, with change and
# delta notification, driven along the safe path.

import gymnasium as gym
import matplotlib.pyplot as plt

import ns_pz
from ns_pz import nature as native
from ns_pz.compat.schedulers import DiscreteScheduler, PeriodicScheduler
from ns_pz.compat.update_functions import DistributionDecrementUpdate, DistributionStepWiseUpdate
from ns_pz.compat.wrappers import NSFrozenLakeWrapper

ACTIONS = [2, 2, 1, 1, 1, 2]  # RIGHT, RIGHT, DOWN x3, RIGHT

tunable_params = {"P": DistributionDecrementUpdate(PeriodicScheduler(period=2), k=0.1)}
env = NSFrozenLakeWrapper(
    gym.make("FrozenLake-v1"),
    tunable_params,
    change_notification=True,
    delta_change_notification=True,
    initial_prob_dist=[1.0, 0.0, 0.0],
)
obs, info = env.reset(seed=0)
compat_slips = []
for action in ACTIONS:
    obs, reward, terminated, truncated, info = env.step(action)
    compat_slips.append(env.get_params()["P"])
    if terminated or truncated:
        break
print(f"last observation: {obs}")
planner = env.get_planning_env()
print(f"planning env's slip vector {planner.get_params()['P']} at t={planner.t}")

# %%
# The same experiment, native
# ---------------------------
#
# Natively a schedule is a nature, every scheduler names its first step, parameters have
# ns_pz's names (``slip`` for NS-Gym's ``P``), and the θ each transition ran under is in
# ``info["theta"]`` when asked for.

schedule = native.ScriptedNature(
    {"slip": native.DistributionDecrementUpdate(native.PeriodicScheduler(2, start=0), k=0.1)}
)
native_env = ns_pz.make_gym(
    "ns_pz/FrozenLake-v0",
    params={"slip": (1.0, 0.0, 0.0)},
    nature=schedule,
    notification="detailed",
    ground_truth_info=True,
)
native_env.reset(seed=0)
native_slips = []
for action in ACTIONS[: len(compat_slips)]:
    _, reward, terminated, truncated, info = native_env.step(action)
    native_slips.append(list(info["theta"]["slip"]))
print(f"native and compat slip trajectories equal: {native_slips == compat_slips}")

fig, ax = plt.subplots(figsize=(5, 3))
ax.plot([s[0] for s in compat_slips], "o-", label="ns_pz.compat")
ax.plot([s[0] for s in native_slips], "x--", label="native", markersize=10)
ax.set_xlabel("transition")
ax.set_ylabel("P(intended move)")
ax.legend()
fig.tight_layout()

# %%
# What compat refuses
# -------------------
#
# NS-Gym accepted a "probability vector" that does not sum to 1; ns_pz refuses it, naming the
# value and what is allowed.

try:
    DistributionStepWiseUpdate(DiscreteScheduler({1}), [[0.5, 0.2, 0.2]])
except ValueError as error:
    print(f"refused: {error}")
