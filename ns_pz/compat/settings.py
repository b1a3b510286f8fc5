"""What the env you wrap was built with, and which of it an NS-Gym wrapper honours.

A wrapper runs an ns_pz family, not the env you pass, so every setting of that env must either
reach the family or stop the wrapper: never may it run a different task than the one you
built. :func:`check_base_env` compares the env with a freshly built default one of its class,
attribute by attribute, which covers the constructors' arguments of Gymnasium 1.2 and 1.4
(``sutton_barto_reward``, ``goal_velocity``, ``g``, FrozenLake's ``desc``, ``reward_schedule``
...) and any constant changed by hand (``x_threshold``, ``max_torque``, ``book_or_nips`` ...).

* Honoured: the parameters (they are θ_0), and the settings listed in :data:`HONOURED` (passed
  to the family); FrozenLake's map and ``reward_schedule`` (read off its table).
* Ignored, as in NS-Gym: the slip the env was built with (``is_slippery``, ``success_rate``);
  the wrapper's ``initial_prob_dist`` sets it.
* Refused with ``ValueError`` naming it: everything else that differs from the default, a
  ``render_mode`` (not supported by ``ns_pz.compat`` yet), and any wrapper around the env
  other than ``TimeLimit`` (honoured as the episode's limit), ``OrderEnforcing`` and
  ``PassiveEnvChecker`` (checks that change nothing); e.g. a ``TransformReward`` belongs
  around the NS-Gym wrapper instead.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ns_pz.compat.families import Binding
from ns_pz.envs.registry import MUJOCO_TASKS

HONOURED: dict[str, tuple[str, ...]] = {
    "CartPoleEnv": ("kinematics_integrator",),
    "MountainCarEnv": ("goal_velocity",),
    "Continuous_MountainCarEnv": ("goal_velocity",),
    "AcrobotEnv": ("torque_noise_max",),
}
"""Env class -> settings passed on to the ns_pz family under the same name."""

DERIVED: dict[str, tuple[str, ...]] = {
    "CartPoleEnv": ("total_mass", "polemass_length"),
    "MountainCarEnv": ("low", "high"),
    "Continuous_MountainCarEnv": ("low_state", "high_state"),
    "FrozenLakeEnv": ("P", "desc", "nrow", "ncol", "initial_state_distrib", "reward_range"),
    "CliffWalkingEnv": ("P", "initial_state_distrib"),
    **{f"{task}Env": ("model", "data", "mujoco_renderer") for task, _, _ in MUJOCO_TASKS},
}
"""Env class -> attributes computed from others (checked through those, or read)."""

STATE = frozenset(
    {
        "spec",
        "render_mode",
        "metadata",
        "action_space",
        "observation_space",
        "np_random",
        "_np_random",
        "_np_random_seed",
        "state",
        "s",
        "lastaction",
        "steps_beyond_terminated",
        "screen",
        "clock",
        "isopen",
        "screen_width",
        "screen_height",
        "screen_dim",
        "window_size",
        "window_surface",
        "cell_size",
        "_ns_pz_core",
    }
)
"""Attributes that hold the episode's state or rendering, not the task."""

NEUTRAL_WRAPPERS = (
    gym.wrappers.TimeLimit,
    gym.wrappers.OrderEnforcing,
    gym.wrappers.PassiveEnvChecker,
)
"""Wrappers that may sit between the env passed and its core (the limit is honoured)."""


def check_base_env(env: gym.Env[Any, Any], binding: Binding) -> dict[str, Any]:
    """Refuse what the wrapper cannot honour; return the settings it passes to the family.

    Returns:
        Family keyword arguments (``goal_velocity``, ``kinematics_integrator``, FrozenLake's
        ``reward_schedule`` as ``(goal, hole, frozen)``, ...), only those that differ from the
        default.

    Raises:
        ValueError: A wrapper other than the neutral ones, a ``render_mode``, or a setting that
            differs from the default and is neither a parameter nor honoured.
    """
    check_wrappers(env)
    base = env.unwrapped
    render_mode = getattr(base, "render_mode", None)
    if render_mode is not None:
        raise ValueError(
            f"render_mode={render_mode!r}: ns_pz.compat cannot render the env it wraps yet (it "
            "runs the ns_pz family, not the env's step); build the env without render_mode"
        )
    if binding.env_class == "Bridge":
        return {}
    cls = getattr(type(base), "_ns_pz_original", type(base))
    default = cls()
    honoured = HONOURED.get(binding.env_class, ())
    skip = STATE | set(binding.names) | set(DERIVED.get(binding.env_class, ())) | set(honoured)
    for name in sorted((set(vars(base)) | set(vars(default))) - skip):
        if name.endswith(("_img", "_imgs")) or name.lstrip("_").startswith("ezpickle_"):
            continue  # pictures; EzPickle's copy of the arguments (the setting itself is named)
        value, usual = getattr(base, name, None), getattr(default, name, None)
        if not _same(value, usual):
            public = name.lstrip("_")
            raise ValueError(
                f"env was built with {public}={value!r} (default {usual!r}), which "
                f"ns_pz.compat's {binding.env_class} does not support: the wrapper would run the "
                f"default task instead; build the env with the default {public}"
            )
    settings = {
        name: getattr(base, name)
        for name in honoured
        if not _same(getattr(base, name), getattr(default, name))
    }
    if binding.env_class == "FrozenLakeEnv":
        schedule = frozen_lake_rewards(base)
        if schedule != frozen_lake_rewards(default):
            settings["reward_schedule"] = schedule
    return settings


def check_wrappers(env: gym.Env[Any, Any]) -> None:
    """Refuse a wrapper between ``env`` and its core other than :data:`NEUTRAL_WRAPPERS`.

    Raises:
        ValueError: Naming the wrapper and where it belongs.
    """
    current: Any = env
    while isinstance(current, gym.Wrapper):
        if not isinstance(current, NEUTRAL_WRAPPERS):
            name = type(current).__name__
            raise ValueError(
                f"env is wrapped in {name}, which an NS-Gym wrapper cannot apply: it runs the "
                f"ns_pz family of {type(env.unwrapped).__name__}, not the env's step. Apply "
                f"{name} around the NS-Gym wrapper instead, e.g. {name}(NSClassicControlWrapper("
                "gym.make(...), ...), ...)"
            )
        current = current.env


def frozen_lake_rewards(base: Any) -> tuple[float, float, float]:
    """FrozenLake's ``reward_schedule`` (goal, hole, frozen), read off its table ``P``.

    Raises:
        ValueError: Entering cells of one letter pays different rewards (a table edited by hand).
    """
    letters = np.asarray(base.desc).astype(str)
    found: dict[str, set[float]] = {"G": set(), "H": set(), "F": set()}
    for state, actions in base.P.items():
        if str(letters.flat[state]) in "GH":
            continue  # the episode has ended there: Gymnasium's table pays 0 to stay
        for outcomes in actions.values():
            for _, next_state, reward, _ in outcomes:
                letter = str(letters.flat[next_state])
                found["F" if letter == "S" else letter].add(float(reward))
    defaults = {"G": 1.0, "H": 0.0, "F": 0.0}
    schedule = []
    for letter in "GHF":
        rewards = found[letter] or {defaults[letter]}
        if len(rewards) > 1:
            raise ValueError(
                f"env's table P pays {sorted(rewards)} for entering {letter!r} cells; "
                "ns_pz.compat supports one reward per cell letter (reward_schedule)"
            )
        schedule.append(rewards.pop())
    return schedule[0], schedule[1], schedule[2]


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.shape(a) == np.shape(b) and np.array_equal(a, b))
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return a is b
