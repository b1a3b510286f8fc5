"""The θ trajectory of an episode, computed without playing it.

An oracle that knows the schedule needs θ_0 .. θ_{H-1}, the parameters that drive transitions
0 .. H-1. For the natures shipped with ns_pz (static, scripted, random) nature's proposals depend
on the step, the θ in force, the budget left and nature's own generator, never on the state or
on the agent's actions. So the trajectory of a seeded episode can be replayed by running only
nature's turns of a copy of the environment's :class:`~ns_pz.process.NSProcess`, seeded alike:
the same projection onto the constraints, the same generators, hence the same θ values bit for
bit as in the real episode (``env.ground_truth()`` after playing it).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ns_pz.nature.policies import RandomNature, ScriptedNature, StaticNature, TrajectoryNature
from ns_pz.params import Params
from ns_pz.process import NATURE, NSProcess

OPEN_LOOP_NATURES = (StaticNature, ScriptedNature, RandomNature, TrajectoryNature)
"""Natures whose θ trajectory is known not to depend on the state or the agent."""


def theta_trajectory(
    env: Any, seed: int, horizon: int | None = None, *, assume_open_loop: bool = False
) -> tuple[Params, ...]:
    """θ_0 .. θ_{H-1} of the episode ``env.reset(seed=seed)`` would start.

    Nature starts from the running episode's θ_0 (one set by ``reset(options={"params": ...})``
    included; before any reset, the env's own).

    ``θ_t`` is the θ in force during transition ``t``, after nature's move at step ``t``. Hand
    changes (``env.set_params``) are not part of the schedule and are not included. Beyond the
    step at which a real episode ends the trajectory is what nature would have done had it
    gone on, which is what a time-indexed policy needs for every state.

    Args:
        env: An ns_pz Gymnasium view (wrapped or not), AEC game, or :class:`NSProcess`. For a
            game, the trajectory is that of its configured nature policy.
        seed: The episode's seed.
        horizon: Number of steps ``H`` (default: the environment's ``max_episode_steps``).
        assume_open_loop: Accept a nature class outside :data:`OPEN_LOOP_NATURES`, on the
            caller's word that its proposals ignore the state and the agent.

    Raises:
        TypeError: ``env`` is none of the above, ``seed`` is not an int, or the nature is not
            known to be open-loop.
        ValueError: No horizon is given and the environment has no time limit, or
            ``horizon < 1``.
    """
    process = _process_of(env)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise TypeError(f"seed={seed!r} must be an int (the seed the episode is reset with)")
    nature = process.nature
    if not assume_open_loop and not isinstance(nature, OPEN_LOOP_NATURES):
        names = ", ".join(cls.__name__ for cls in OPEN_LOOP_NATURES)
        raise TypeError(
            f"nature={nature!r} may make θ depend on the state or the agent, so no θ trajectory "
            f"exists before the episode is played; known open-loop natures: {names} "
            "(pass assume_open_loop=True if yours never reads the state or the agent)"
        )
    horizon = check_horizon(horizon, process.max_episode_steps)
    replay = copy.copy(process)  # seed() and reset() rebind every per-episode attribute
    replay.seed(seed)
    # From the running episode's θ_0, which reset options may have set (nature starts there).
    theta0 = process.theta0
    replay.reset(None if theta0 == process.base_theta0 else {"params": theta0})
    thetas = []
    for t in range(horizon):
        replay.t, replay.turn, replay.done = t, NATURE, False  # nature's turns only, no transitions
        replay.nature_turn(replay.scripted_proposal())
        thetas.append(replay.theta)
    return tuple(thetas)


def initial_theta(env: Any) -> Params:
    """θ at reset, before nature's first move: what an agent plans with before transition 0.

    ``theta_trajectory(env, seed)[0]`` is the θ of transition 0, after nature's move at step 0;
    the two differ when a schedule changes θ at step 0. The stale planner plans with this θ
    throughout, the snapshot planner before transition 0.

    Raises:
        TypeError: ``env`` is not an ns_pz environment (as :func:`theta_trajectory`).
    """
    return _process_of(env).theta0


def check_horizon(horizon: object, default: int | None = None) -> int:
    """Validate a horizon (``None``: ``default``, which must then exist).

    Raises:
        TypeError: ``horizon`` is not an int.
        ValueError: It is below 1, or ``None`` with no default.
    """
    if horizon is None:
        if default is None:
            raise ValueError(
                "horizon=None but the environment has no time limit; pass horizon= explicitly"
            )
        horizon = default
    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)):
        raise TypeError(f"horizon={horizon!r} must be an int >= 1")
    if horizon < 1:
        raise ValueError(f"horizon={horizon!r} must be >= 1")
    return int(horizon)


def _process_of(env: Any) -> NSProcess:
    """The process behind a view, a wrapped view, a game or a process."""
    if isinstance(env, NSProcess):
        return env
    base = getattr(env, "unwrapped", env)
    process = getattr(base, "_process", None)
    if not isinstance(process, NSProcess):
        raise TypeError(
            f"env={env!r} is not an ns_pz environment (Gymnasium view, AEC game or NSProcess)"
        )
    return process
