"""The one registry of ns_pz environments.

Every id names an environment family with default constructor arguments and a default time
limit. Three ways to build one:

* ``gymnasium.make("ns_pz/FrozenLake-v0", ...)``: the Gymnasium view, with Gymnasium's usual
  wrappers; ``max_episode_steps=`` of ``gymnasium.make`` overrides the limit (``-1``: none), as
  for any Gymnasium env, and the view enforces it by itself, not a ``TimeLimit`` wrapper, so its
  planning copies continue the limit (:mod:`ns_pz.envs.time_limit`);
* :func:`make_gym`: the same view, unwrapped, truncating by itself;
* :func:`make`: the PettingZoo AEC game.

Keyword arguments are split: ``params``, ``nature``, ``monitor``, ``notification``,
``constraints``, ``max_episode_steps``, ``render_mode`` (and ``ground_truth_info`` /
``nature_reward`` for the view / game) configure the NS-MDP; everything else goes to the
family's constructor (``map_name="8x8"``).
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium
from ns_pz.envs.time_limit import WRAPPER_SPEC as VIEW_TIME_LIMIT

from ns_pz.errors import UnknownEnvironment
from ns_pz.family import EnvFamily
from ns_pz.game import NSGame
from ns_pz.regret import default_reference
from ns_pz.vector import NSVectorEnv
from ns_pz.views import NSGymEnv

_NS_KWARGS = {
    "params",
    "nature",
    "monitor",
    "notification",
    "constraints",
    "max_episode_steps",
    "render_mode",
}
_VIEW_KWARGS = _NS_KWARGS | {"ground_truth_info"}
_VECTOR_KWARGS = (_NS_KWARGS - {"render_mode"}) | {"autoreset_mode"}
_GAME_KWARGS = _NS_KWARGS | {
    "nature_reward",
    "regret_reference",
    "nature_action",
    "nature_observes_state",
    "monitor_action",
    "monitor_reward",
}


@dataclass(frozen=True)
class NSEnvSpec:
    """A registered environment: its family, default arguments and time limit.

    ``entry_point`` is the family class, or ``"module:Class"`` for one imported on first use
    (the MuJoCo families, so that ``import ns_pz`` does not load MuJoCo).
    """

    id: str
    entry_point: type[EnvFamily] | str
    max_episode_steps: int
    description: str
    family_kwargs: Mapping[str, Any] = field(default_factory=dict)

    @property
    def family(self) -> type[EnvFamily]:
        """The family class (imported now if registered by name)."""
        if isinstance(self.entry_point, str):
            module, _, name = self.entry_point.partition(":")
            return getattr(importlib.import_module(module), name)  # type: ignore[no-any-return]
        return self.entry_point

    def build_family(self, overrides: Mapping[str, Any], ns_names: set[str]) -> EnvFamily:
        """The family with the registered arguments, updated by ``overrides``.

        Raises:
            TypeError: An argument neither the family's constructor nor ``ns_names`` takes.
        """
        kwargs = {**self.family_kwargs, **overrides}
        signature = inspect.signature(self.family)
        for name in kwargs:
            if name not in signature.parameters:
                allowed = sorted(set(signature.parameters) | ns_names)
                raise TypeError(f"{self.id} takes no argument {name!r} here; allowed: {allowed}")
        return self.family(**kwargs)


_SPECS: dict[str, NSEnvSpec] = {}


def register(
    id: str,
    family: type[EnvFamily] | str,
    *,
    max_episode_steps: int,
    description: str,
    **family_kwargs: Any,
) -> None:
    """Register an environment with ns_pz and with Gymnasium (which makes it conformance-tested).

    ``family`` is a class or ``"module:Class"``, imported when the environment is first made.
    """
    _SPECS[id] = NSEnvSpec(id, family, max_episode_steps, description, dict(family_kwargs))
    gymnasium.register(
        id=id,
        entry_point="ns_pz.envs.registry:_gymnasium_entry_point",
        max_episode_steps=max_episode_steps,
        additional_wrappers=(VIEW_TIME_LIMIT,),
        kwargs={"env_id": id},
    )


def registered_envs() -> tuple[str, ...]:
    """Ids of every registered environment, sorted."""
    return tuple(sorted(_SPECS))


def spec(env_id: str) -> NSEnvSpec:
    """The registration of ``env_id``.

    Raises:
        UnknownEnvironment: ``env_id`` is not registered (the message suggests close ids).
    """
    try:
        return _SPECS[env_id]
    except KeyError:
        if env_id in MUJOCO_IDS:  # registered only with the extra, so it is missing
            raise UnknownEnvironment(
                f'{env_id} needs MuJoCo, which is not installed: pip install "ns_pz[mujoco]"'
            ) from None
        close = difflib.get_close_matches(env_id, _SPECS, n=3)
        hint = f" Did you mean {', '.join(map(repr, close))}?" if close else ""
        raise UnknownEnvironment(
            f"no environment {env_id!r} is registered.{hint} Registered: {', '.join(_SPECS)}"
        ) from None


def make(env_id: str, **kwargs: Any) -> NSGame:
    """The PettingZoo AEC game of a registered environment."""
    env_spec = spec(env_id)
    ns_kwargs, family_kwargs = _split(kwargs, _GAME_KWARGS)
    ns_kwargs.setdefault("max_episode_steps", env_spec.max_episode_steps)
    family = env_spec.build_family(family_kwargs, _GAME_KWARGS)
    if ns_kwargs.get("nature_reward") == "regret" and ns_kwargs.get("regret_reference") is None:
        ns_kwargs["regret_reference"] = default_reference(family)
    return NSGame(family, **ns_kwargs)


def make_gym(env_id: str, **kwargs: Any) -> NSGymEnv:
    """The Gymnasium view of a registered environment, unwrapped, with its own time limit."""
    env_spec = spec(env_id)
    ns_kwargs, family_kwargs = _split(kwargs, _VIEW_KWARGS)
    ns_kwargs.setdefault("max_episode_steps", env_spec.max_episode_steps)
    return NSGymEnv(env_spec.build_family(family_kwargs, _VIEW_KWARGS), **ns_kwargs)


def make_vec(env_id: str, num_envs: int = 1, **kwargs: Any) -> NSVectorEnv:
    """The native vector env of a registered environment: ``num_envs`` views stepped together.

    Keyword arguments are those of :func:`make_gym` (without ``render_mode`` and
    ``ground_truth_info``) plus ``autoreset_mode``; see :class:`~ns_pz.vector.NSVectorEnv`.
    """
    from ns_pz.envs.batched import kernel_for

    env_spec = spec(env_id)
    ns_kwargs, family_kwargs = _split(kwargs, _VECTOR_KWARGS)
    ns_kwargs.setdefault("max_episode_steps", env_spec.max_episode_steps)
    family = env_spec.build_family(family_kwargs, _VECTOR_KWARGS)
    return NSVectorEnv(family, num_envs, kernel=kernel_for(family), **ns_kwargs)


def _gymnasium_entry_point(env_id: str, **kwargs: Any) -> NSGymEnv:
    """What ``gymnasium.make`` calls; :class:`ViewTimeLimit` then sets the view's limit."""
    env_spec = spec(env_id)
    ns_kwargs, family_kwargs = _split(kwargs, _VIEW_KWARGS)
    ns_kwargs["max_episode_steps"] = None
    return NSGymEnv(env_spec.build_family(family_kwargs, _VIEW_KWARGS), **ns_kwargs)


def _split(kwargs: Mapping[str, Any], ns_names: set[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    ns_kwargs = {k: v for k, v in kwargs.items() if k in ns_names}
    family_kwargs = {k: v for k, v in kwargs.items() if k not in ns_names}
    return ns_kwargs, family_kwargs


def _register_mujoco() -> None:
    """The MuJoCo tasks, when the ``mujoco`` extra is installed (found, not imported).

    Without it, Gymnasium still knows the ids, so that ``gymnasium.make`` reaches
    :func:`spec`, whose error names the extra to install.
    """
    if importlib.util.find_spec("mujoco") is None:
        for env_id in MUJOCO_IDS:
            gymnasium.register(
                id=env_id,
                entry_point="ns_pz.envs.registry:_gymnasium_entry_point",
                kwargs={"env_id": env_id},
            )
        return
    for name, limit, theta in MUJOCO_TASKS:
        # Gymnasium's {name}-v5 with NS-Gym's knobs as θ.
        register(
            f"ns_pz/{name}-v0",
            f"ns_pz.envs.mujoco_tasks:{name}Family",
            max_episode_steps=limit,
            description=f"{name}-v5 (MuJoCo); θ: {theta}",
        )


# --- the registered environments ------------------------------------------------------------
from ns_pz.envs.acrobot import AcrobotFamily  # noqa: E402
from ns_pz.envs.bridge import BridgeFamily, SplitBridgeFamily  # noqa: E402
from ns_pz.envs.cartpole import CartPoleFamily  # noqa: E402
from ns_pz.envs.cliff_walking import CliffWalkingFamily  # noqa: E402
from ns_pz.envs.frozen_lake import FrozenLakeFamily  # noqa: E402
from ns_pz.envs.mountain_car import MountainCarContinuousFamily, MountainCarFamily  # noqa: E402
from ns_pz.envs.pendulum import PendulumFamily  # noqa: E402

# CartPole-v1's physics with gravity, masses, length, force and time step as θ.
register(
    "ns_pz/CartPole-v0",
    CartPoleFamily,
    max_episode_steps=500,
    description="CartPole; θ: gravity, masscart, masspole, length, force_mag, tau",
)
# MountainCar-v0's physics with gravity and push force as θ.
register(
    "ns_pz/MountainCar-v0",
    MountainCarFamily,
    max_episode_steps=200,
    description="MountainCar; θ: gravity, force; goal_velocity=",
)
# MountainCarContinuous-v0's physics with gravity (a constant in Gymnasium) and power as θ.
register(
    "ns_pz/MountainCarContinuous-v0",
    MountainCarContinuousFamily,
    max_episode_steps=999,
    description="MountainCarContinuous; θ: gravity, power; goal_velocity=",
)
# Acrobot-v1's book dynamics with link lengths, masses, centres of mass, inertia and dt as θ.
register(
    "ns_pz/Acrobot-v0",
    AcrobotFamily,
    max_episode_steps=500,
    description="Acrobot; θ: link_length_1/2, link_mass_1/2, link_com_pos_1/2, link_moi, dt; "
    "torque_noise_max=",
)
# Pendulum-v1's physics with mass, length, gravity and dt as θ.
register(
    "ns_pz/Pendulum-v0",
    PendulumFamily,
    max_episode_steps=200,
    description="Pendulum; θ: mass, length, gravity, dt",
)
# FrozenLake-v1 (4x4) with the slip vector [intended, action+1, action-1] as θ.
register(
    "ns_pz/FrozenLake-v0",
    FrozenLakeFamily,
    max_episode_steps=100,
    description="FrozenLake 4x4; θ: slip vector",
    map_name="4x4",
)
# The 8x8 lake, same θ.
register(
    "ns_pz/FrozenLake8x8-v0",
    FrozenLakeFamily,
    max_episode_steps=200,
    description="FrozenLake 8x8; θ: slip vector",
    map_name="8x8",
)
# CliffWalking-v1 (4x12) with the slip vector [intended, action+1, action-1, reverse] as θ.
register(
    "ns_pz/CliffWalking-v0",
    CliffWalkingFamily,
    max_episode_steps=200,
    description="CliffWalking 4x12; θ: slip vector; goal_reward= (paper: 100)",
)
# Lecarpentier's Bridge with one global slip vector (the NS-Gym paper's setting).
register(
    "ns_pz/Bridge-v0",
    BridgeFamily,
    max_episode_steps=200,
    description="Bridge 5x8; θ: slip vector; map_name='extra_hole' for NS-Gym's later map",
)
# The Bridge with separate slip vectors for the left and right halves.
register(
    "ns_pz/BridgeSplit-v0",
    SplitBridgeFamily,
    max_episode_steps=200,
    description="Bridge 5x8; θ: slip_left (columns 0-3), slip_right (columns 4-7)",
)

# NS-Gym's Bridge behind NS-Gym's API (ns_pz.compat), in a namespace of its own so both packages
# can coexist. Gymnasium only: it is a compat env, not an ns_pz family. The entry point is a
# string, so ns_pz.compat loads when the env is made, not on `import ns_pz`.
COMPAT_BRIDGE_ID = "ns_pz_compat/Bridge-v0"
gymnasium.register(
    id=COMPAT_BRIDGE_ID, entry_point="ns_pz.compat.envs.Bridge:Bridge", max_episode_steps=100
)
# Gymnasium's v5 MuJoCo tasks (name, time limit, θ), registered only with the mujoco extra.
MUJOCO_TASKS: tuple[tuple[str, int, str], ...] = (
    ("InvertedPendulum", 1000, "gravity, pole/cart masses, rail friction and damping, tilt, gain"),
    ("InvertedDoublePendulum", 1000, "gravity, three masses, rail friction, damping, tilt, gain"),
    ("Reacher", 50, "body0/body1 masses, joint0/joint1 damping, actuator_gain"),
    ("Swimmer", 1000, "torso/mid/back masses, rotor damping, actuator_gain"),
    ("Pusher", 100, "gravity, four arm-link masses, three joint dampings, actuator_gain"),
    ("Hopper", 1000, "gravity, four masses, floor_friction, joint damping, tilt, gain"),
    ("Walker2d", 1000, "gravity, seven masses, floor_friction, six dampings, tilt, gain"),
    ("HalfCheetah", 1000, "gravity, seven masses, floor_friction, six dampings, tilt, gain"),
    ("Ant", 1000, "gravity, torso_mass, floor_friction, tilt, gain"),
    ("Humanoid", 1000, "gravity, thirteen masses, floor_friction, knee/elbow damping, tilt, gain"),
    ("HumanoidStandup", 1000, "gravity, 13 masses, floor_friction, knee/elbow damping, tilt, gain"),
)
MUJOCO_IDS = frozenset(f"ns_pz/{name}-v0" for name, _, _ in MUJOCO_TASKS)
_register_mujoco()
