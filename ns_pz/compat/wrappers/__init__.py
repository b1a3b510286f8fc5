"""NS-Gym's wrappers (``ns_gym.wrappers``), as thin adapters over the ns_pz core.

Submodules as in NS-Gym: :mod:`~ns_pz.compat.wrappers.classic_control`
(``NSClassicControlWrapper``) and :mod:`~ns_pz.compat.wrappers.toy_text`
(``NSFrozenLakeWrapper``, ``NSCliffWalkingWrapper``, ``NSBridgeWrapper``) and
:mod:`~ns_pz.compat.wrappers.mujoco_env` (``MujocoWrapper``, loaded on first use: it needs the
``mujoco`` extra); the base class ``NSWrapper`` is in :mod:`~ns_pz.compat.wrappers.core` (and, as
in NS-Gym, importable from :mod:`ns_pz.compat.base`). NS-Gym's Box2D, pursuit-evasion and city
wrappers have no ns_pz family: their names and modules raise ``ImportError`` saying so.
"""

from typing import Any

from ns_pz.compat.wrappers.classic_control import NSClassicControlWrapper
from ns_pz.compat.wrappers.core import GROUND_TRUTH_CHANGE, GROUND_TRUTH_DELTA, NSWrapper
from ns_pz.compat.wrappers.toy_text import (
    NSBridgeWrapper,
    NSCliffWalkingWrapper,
    NSFrozenLakeWrapper,
)

__all__ = [
    "GROUND_TRUTH_CHANGE",
    "GROUND_TRUTH_DELTA",
    "NSBridgeWrapper",
    "NSClassicControlWrapper",
    "NSCliffWalkingWrapper",
    "NSFrozenLakeWrapper",
    "NSWrapper",
]

UNSUPPORTED = {
    "NSBox2dWrapper": "Box2D",
    "PursuitEvasionWrapper": "pursuit-evasion",
}
"""NS-Gym wrappers without an ns_pz family -> what they wrap."""


def unsupported(name: str) -> ImportError:
    """The error for NS-Gym's wrapper ``name``, which ns_pz.compat does not provide."""
    return ImportError(
        f"ns_pz.compat has no {name}: ns_pz has no {UNSUPPORTED[name]} family yet (supported: "
        "NSClassicControlWrapper, NSFrozenLakeWrapper, NSCliffWalkingWrapper, NSBridgeWrapper, "
        "MujocoWrapper)"
    )


def __getattr__(name: str) -> Any:
    if name == "MujocoWrapper":  # imports MuJoCo, so only when asked for
        from ns_pz.compat.wrappers.mujoco_env import MujocoWrapper

        return MujocoWrapper
    if name in UNSUPPORTED:
        raise unsupported(name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
