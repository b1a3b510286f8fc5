"""Moving an NS-Gym experiment to ns_pz: same code through ns_pz.compat, then the native API.

Step 1 is NS-Gym code with ``ns_gym`` replaced by ``ns_pz.compat``. Step 2 is the same
experiment written natively; the two produce the same parameter trajectory, because the compat
classes run the native ones (the only change: native schedules name their start step).
"""

import gymnasium as gym

import ns_pz
from ns_pz import nature as native
from ns_pz.compat.schedulers import DiscreteScheduler, PeriodicScheduler
from ns_pz.compat.update_functions import DistributionDecrementUpdate, DistributionStepWiseUpdate
from ns_pz.compat.wrappers import NSFrozenLakeWrapper

ACTIONS = [2, 2, 1, 1, 1, 2]  # RIGHT, RIGHT, DOWN x3, RIGHT: the way to the goal if nothing slips

# -- 1. NS-Gym code, package name changed -----------------------------------------------------
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
print(f"compat: {len(compat_slips)} steps, last obs {obs}")
print(f"compat: slip vector now {[round(p, 3) for p in compat_slips[-1]]}")

# Planning: told the size of changes (delta notification), the planner sees the current slip.
planner = env.get_planning_env()
print(f"compat: planning env slip {planner.get_params()['P']} at t={planner.t}")

# -- 2. the same experiment, native ------------------------------------------------------------
schedule = native.ScriptedNature(
    {"slip": native.DistributionDecrementUpdate(native.PeriodicScheduler(2, start=0), k=0.1)}
)
native_env = ns_pz.make_gym(
    "ns_pz/FrozenLake-v0",
    params={"slip": (1.0, 0.0, 0.0)},
    nature=schedule,
    notification="detailed",
    ground_truth_info=True,  # info["theta"]: the θ each transition ran under (evaluation only)
)
native_obs, _ = native_env.reset(seed=0)
native_slips = []
for action in ACTIONS[: len(compat_slips)]:
    native_obs, reward, terminated, truncated, info = native_env.step(action)
    native_slips.append(list(info["theta"]["slip"]))
print(f"native: last obs {native_obs}")
print(f"native and compat slip trajectories equal: {native_slips == compat_slips}")

# -- 3. what compat refuses that NS-Gym silently accepted --------------------------------------
try:
    DistributionStepWiseUpdate(DiscreteScheduler({1}), [[0.5, 0.2, 0.2]])
except ValueError as error:
    print(f"refused: {error}")
