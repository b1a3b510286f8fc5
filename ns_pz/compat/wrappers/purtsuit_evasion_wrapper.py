"""NS-Gym's ``ns_gym.wrappers.purtsuit_evasion_wrapper``: not provided; importing it raises."""

from ns_pz.compat.wrappers import unsupported

raise unsupported("PursuitEvasionWrapper")
