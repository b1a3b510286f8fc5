"""Which ns_pz family runs a Gymnasium environment, and NS-Gym's parameter names for its θ.

NS-Gym names parameters after the attributes of Gymnasium's env classes (``masspole``,
``LINK_LENGTH_1``, ``m``, ``P``); ns_pz names the fields of its θ classes. A :class:`Binding`
holds the translation for one env class. Family modules are imported on first use, so a family
that is not installed only matters to the wrapper that needs it.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym

from ns_pz.family import EnvFamily


@dataclass(frozen=True)
class Binding:
    """How one Gymnasium env class maps onto an ns_pz family.

    Attributes:
        env_class: The class name of the env (``type(env.unwrapped).__name__``).
        module: The module holding the family.
        family: The family class name.
        names: NS-Gym parameter name -> ns_pz θ field name.
        gym_id: The Gymnasium id NS-Gym builds this env with.
        derived: θ properties NS-Gym's env also holds as attributes (CartPole's
            ``total_mass``), readable like the parameters.
        table_attribute: The attribute holding the transition table ``P[s][a]`` (FrozenLake's
            ``P``, the Bridge's ``transition_matrix``), if any; it takes precedence over a
            parameter of the same name, which is then read as the wrapper's ``transition_prob``.
        adopted: Attributes of the env you wrap that become views onto θ (default: the
            parameters, the derived ones and the table).
        aliases: Other NS-Gym names of parameters (the Bridge's ``left_side_prob`` for
            ``P_left``) -> the parameter name; readable like it.
        native_names: ns_pz θ field name -> NS-Gym name.
        readable: Every attribute an NS-Gym wrapper's ``unwrapped`` shows.
    """

    env_class: str
    module: str
    family: str
    names: Mapping[str, str]
    gym_id: str
    derived: tuple[str, ...] = ()
    table_attribute: str | None = None
    adopted: tuple[str, ...] = ()
    aliases: Mapping[str, str] = field(default_factory=dict)
    native_names: Mapping[str, str] = field(init=False)
    readable: frozenset[str] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "native_names", {v: k for k, v in self.names.items()})
        table = () if self.table_attribute is None else (self.table_attribute,)
        readable = frozenset((*self.names, *self.aliases, *self.derived, *table))
        object.__setattr__(self, "readable", readable)
        if not self.adopted:
            object.__setattr__(self, "adopted", tuple(sorted(readable)))

    def family_class(self) -> type[EnvFamily]:
        """The family class (its module imported now).

        Raises:
            ValueError: The module is not part of this installation of ns_pz.
        """
        try:
            module = importlib.import_module(self.module)
        except ModuleNotFoundError as error:
            if error.name is not None and self.module.startswith(error.name):
                raise ValueError(
                    f"{self.env_class} needs the ns_pz family {self.module}.{self.family}, "
                    "which this installation of ns_pz does not have"
                ) from None
            raise
        return getattr(module, self.family)  # type: ignore[no-any-return]


_CARTPOLE = ("gravity", "masscart", "masspole", "force_mag", "tau", "length")
_ACROBOT = {
    "dt": "dt",
    "LINK_LENGTH_1": "link_length_1",
    "LINK_LENGTH_2": "link_length_2",
    "LINK_MASS_1": "link_mass_1",
    "LINK_MASS_2": "link_mass_2",
    "LINK_COM_POS_1": "link_com_pos_1",
    "LINK_COM_POS_2": "link_com_pos_2",
    "LINK_MOI": "link_moi",
}

CLASSIC_CONTROL: dict[str, Binding] = {
    b.env_class: b
    for b in (
        Binding(
            "CartPoleEnv",
            "ns_pz.envs.cartpole",
            "CartPoleFamily",
            {n: n for n in _CARTPOLE},
            "CartPole-v1",
            derived=("total_mass", "polemass_length"),
        ),
        Binding(
            "MountainCarEnv",
            "ns_pz.envs.mountain_car",
            "MountainCarFamily",
            {"gravity": "gravity", "force": "force"},
            "MountainCar-v0",
        ),
        Binding(
            "Continuous_MountainCarEnv",
            "ns_pz.envs.mountain_car",
            "MountainCarContinuousFamily",
            {"power": "power"},
            "MountainCarContinuous-v0",
        ),
        Binding("AcrobotEnv", "ns_pz.envs.acrobot", "AcrobotFamily", _ACROBOT, "Acrobot-v1"),
        Binding(
            "PendulumEnv",
            "ns_pz.envs.pendulum",
            "PendulumFamily",
            {"m": "mass", "l": "length", "g": "gravity", "dt": "dt"},
            "Pendulum-v1",
        ),
    )
}
"""NS-Gym's ``SUPPORTED_CLASSIC_CONTROL_ENV_IDS``, by env class name."""

FROZEN_LAKE = Binding(
    "FrozenLakeEnv",
    "ns_pz.envs.frozen_lake",
    "FrozenLakeFamily",
    {"P": "slip"},
    "FrozenLake-v1",
    table_attribute="P",
)
CLIFF_WALKING = Binding(
    "CliffWalkingEnv",
    "ns_pz.envs.cliff_walking",
    "CliffWalkingFamily",
    {"P": "slip"},
    "CliffWalking-v1",
    table_attribute="P",
)
# The Bridge is ns_pz.compat's own env: its slip attributes and table derive from its ``theta``.
BRIDGE = Binding(
    "Bridge",
    "ns_pz.envs.bridge",
    "BridgeFamily",
    {"P": "slip"},
    "Bridge-v0",
    table_attribute="transition_matrix",
    adopted=("theta",),
)
SPLIT_BRIDGE = Binding(
    "Bridge",
    "ns_pz.envs.bridge",
    "SplitBridgeFamily",
    {"P_left": "slip_left", "P_right": "slip_right"},
    "Bridge-v0",
    table_attribute="transition_matrix",
    adopted=("theta",),
    aliases={"left_side_prob": "P_left", "right_side_prob": "P_right"},
)

GRID_DEFAULTS: dict[str, dict[str, list[float]]] = {
    "FrozenLakeEnv": {"P": [1.0, 0.0, 0.0]},
    "CliffWalkingEnv": {"P": [1.0, 0.0, 0.0, 0.0]},
    "Bridge": {"P": [1.0, 0.0, 0.0], "P_left": [1.0, 0.0, 0.0], "P_right": [1.0, 0.0, 0.0]},
}
"""The slip vectors the grid wrappers start from by default (their ``initial_prob_dist``)."""


def env_class_name(env: gym.Env[Any, Any]) -> str:
    """The class name of the innermost env (what NS-Gym keys its tables by).

    Raises:
        TypeError: ``env`` is not a Gymnasium env.
    """
    if not isinstance(env, gym.Env):
        raise TypeError(f"env={env!r} must be a Gymnasium env, e.g. gymnasium.make('CartPole-v1')")
    return type(env.unwrapped).__name__


def time_limit(env: gym.Env[Any, Any]) -> int | None:
    """The ``max_episode_steps`` of the first ``TimeLimit`` wrapping ``env`` (None if none)."""
    current: Any = env
    while isinstance(current, gym.Wrapper):
        if isinstance(current, gym.wrappers.TimeLimit):
            return int(current._max_episode_steps)
        current = current.env
    return None


def classic_control_params(binding: Binding, env: gym.Env[Any, Any]) -> dict[str, Any]:
    """θ_0 of a classic-control env: each mapped attribute read from ``env.unwrapped``."""
    base = env.unwrapped
    return {
        native: getattr(base, name) for name, native in binding.names.items() if hasattr(base, name)
    }


def tunable_defaults() -> dict[str, dict[str, Any]]:
    """NS-Gym's ``TUNABLE_PARAMS``: env class name -> {NS-Gym name: default}.

    Classic-control and MuJoCo entries (the latter with the ``mujoco`` extra) come from the θ
    defaults of the installed families (which are Gymnasium's defaults); grid entries are the
    wrappers' default slip vectors.
    """
    table: dict[str, dict[str, Any]] = {}
    for name, binding in CLASSIC_CONTROL.items():
        try:
            params_cls = binding.family_class().params_cls
        except ValueError:
            continue
        table[name] = {
            ns_gym_name: params_cls.spec(native).default
            for ns_gym_name, native in binding.names.items()
        }
    for name, defaults in GRID_DEFAULTS.items():
        table[name] = {k: list(v) for k, v in defaults.items()}
    if importlib.util.find_spec("mujoco") is not None:
        from ns_pz.compat.wrappers.mujoco_env import MUJOCO

        for name, binding in MUJOCO.items():
            params_cls = binding.family_class().params_cls
            table[name] = {k: params_cls.spec(v).default for k, v in binding.names.items()}
    return table
