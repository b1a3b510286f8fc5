"""NS-Gym's ``ns_gym.wrappers.box_2d``: not provided (Box2D); importing it raises."""

from ns_pz.compat.wrappers import unsupported

raise unsupported("NSBox2dWrapper")
