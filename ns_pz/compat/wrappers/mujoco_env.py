"""NS-Gym's ``ns_gym.wrappers.mujoco_env``: not provided (MuJoCo); importing it raises."""

from ns_pz.compat.wrappers import unsupported

raise unsupported("MujocoWrapper")
