"""NS-Gym's ``ns_gym.wrappers.mujoco_env``: ``MujocoWrapper`` over the ns_pz MuJoCo families.

Needs the ``mujoco`` extra. The env you wrap (``gymnasium.make("HalfCheetah-v5")``) is read, not
stepped: θ_0 is read from its model (so masses you changed before wrapping are kept) and the
ns_pz family of its class runs the task. Differences from NS-Gym's ``MujocoWrapper``, beyond
those of every ``ns_pz.compat`` wrapper:

* ``gravity`` is the z component of the gravity vector, a number, both in ``tunable_params``
  (NS-Gym also hands its update function the z component) and in :meth:`get_params` (NS-Gym
  shows the vector);
* a change that would leave a parameter's range (a mass outside 0.2 to 5 times Gymnasium's)
  is projected onto it, not dropped with a ``ConstraintViolationWarning``;
* planning envs are the core's planning copies: a save of the MuJoCo state, not a new
  ``gymnasium.make`` per copy;
* other model edits made by hand before wrapping (a geom size, a joint range) are not carried
  over: only θ's fields are read from the model;
* masses change without their inertia, as in NS-Gym (the core's families scale the inertia
  with the mass by default: ``scale_inertia=True``);
* ``floor_friction`` scales every geom's friction with the floor's, so that lowering it acts
  (MuJoCo gives a contact the larger coefficient of its two geoms); NS-Gym sets the floor's
  alone. The pendulums' ``rail_friction`` is the slider joint's dry friction in N (default 0):
  NS-Gym's (the rail geom's friction) has no effect, since the cart touches nothing, and
  InvertedDoublePendulum's ``floor_friction`` (the same rail geom) is gone for the same reason;
* θ has knobs NS-Gym lacks: ``gravity_tilt``, ``actuator_gain`` and the pendulums'
  ``slider_damping``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from ns_pz.compat.families import Binding, env_class_name
from ns_pz.compat.wrappers.core import ScalarWrapper
from ns_pz.envs import mujoco_tasks
from ns_pz.envs.mujoco_family import MujocoFamily
from ns_pz.family import EnvFamily
from ns_pz.params import Params

__all__ = ["MUJOCO", "MujocoWrapper"]


def _binding(task: str) -> Binding:
    family: type[MujocoFamily] = getattr(mujoco_tasks, f"{task}Family")
    return Binding(
        f"{task}Env",
        "ns_pz.envs.mujoco_tasks",
        f"{task}Family",
        {knob.name: knob.name for knob in family.knobs},
        f"{task}-v5",
    )


MUJOCO: dict[str, Binding] = {b.env_class: b for b in map(_binding, mujoco_tasks.TASKS)}
"""NS-Gym's ``SUPPORTED_MUJOCO_ENV_IDS`` (and Walker2d), by env class name."""


class MujocoWrapper(ScalarWrapper):
    """A Gymnasium v5 MuJoCo env (Ant, HalfCheetah, Hopper, Humanoid, ...) made non-stationary.

    ``tunable_params`` maps NS-Gym's parameter names (``torso_mass``, ``gravity``,
    ``floor_friction``, ``bthigh_damping`` ...; :data:`MUJOCO` lists them per class) to
    ``ns_pz.compat`` update functions.
    """

    _accepts = "a Gymnasium v5 MuJoCo env (gymnasium.make('HalfCheetah-v5'), ...)"

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        binding = MUJOCO.get(env_class_name(env))
        if binding is None:
            raise self._unsupported(env, list(MUJOCO))
        return binding

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        family_class: type[MujocoFamily] = binding.family_class()  # type: ignore[assignment]
        family = family_class(scale_inertia=False, **settings)  # masses alone, as NS-Gym
        return family, family.params_of_model(env.unwrapped.model)  # type: ignore[attr-defined]
