"""NS-Gym's ``ns_gym.envs``: the Bridge (class in :mod:`ns_pz.compat.envs.Bridge`, as in NS-Gym)."""

from ns_pz.compat.envs.Bridge import Bridge

__all__ = ["Bridge"]
