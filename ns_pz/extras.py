"""Optional dependencies: import one, or fail with the ``ns_pz`` extra that installs it.

The core needs gymnasium, pettingzoo and numpy only. Parts that need more import it on use
through :func:`require`, so a missing package is reported as the extra to install (``pip install
"ns_pz[game]"``) rather than as a bare ``No module named 'scipy'`` deep in a solver.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from ns_pz.errors import MissingExtra

#: The extra that provides each optional top-level package.
EXTRAS = {
    "scipy": "game",
    "matplotlib": "plot",
    "torch": "learn",
    "stable_baselines3": "learn",
    "ray": "ray",
    "pygame": "render",
    "mujoco": "mujoco",
    "pyspiel": "openspiel",
    "open_spiel": "openspiel",
}


def require(module: str, purpose: str, extra: str | None = None) -> ModuleType:
    """Import ``module``, or raise :class:`MissingExtra` naming the extra that provides it.

    Args:
        module: A dotted module name whose top-level package is one of :data:`EXTRAS`.
        purpose: What needs it, to start the message (``"solve_game"``).
        extra: The extra to name, where it is not the package's own (``"rllib"`` for Ray's
            RLlib); ``None``: the one :data:`EXTRAS` lists.

    Raises:
        MissingExtra: The top-level package is not installed (an ``ImportError``).
        ValueError: ``module``'s package is not one an extra provides.
    """
    top = module.split(".")[0]
    extra = EXTRAS.get(top) if extra is None else extra
    if extra is None:
        raise ValueError(f"module={module!r} is in no ns_pz extra; known: {sorted(EXTRAS)}")
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        missing = error.name or ""
        if not (module == missing or module.startswith(missing + ".")) or not missing:
            raise  # something else is missing, inside an installed package: its error says more
        raise MissingExtra(
            f'{purpose} needs {top}, which is not installed: pip install "ns_pz[{extra}]"'
            f"{_torch_note(top)}"
        ) from None


def _torch_note(top: str) -> str:
    if top != "torch":
        return ""
    return (
        " (for the small CPU-only torch wheel, first: pip install torch==2.13.0 "
        "--index-url https://download.pytorch.org/whl/cpu)"
    )
