"""NS-Gym's update functions: scalar (``single_param``) and probability vector (``distribution``).

``from ns_pz.compat.update_functions import *`` brings every class of both, as NS-Gym's does.
"""

from ns_pz.compat.update_functions.distribution import *  # noqa: F403
from ns_pz.compat.update_functions.distribution import __all__ as _distribution
from ns_pz.compat.update_functions.single_param import *  # noqa: F403
from ns_pz.compat.update_functions.single_param import __all__ as _single_param

__all__ = [*_distribution, *_single_param]
