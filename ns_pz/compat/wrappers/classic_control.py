"""NS-Gym's ``ns_gym.wrappers.classic_control``: the classic-control wrapper."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from ns_pz.compat.families import (
    CLASSIC_CONTROL,
    Binding,
    classic_control_params,
    env_class_name,
)
from ns_pz.compat.wrappers.core import ScalarWrapper
from ns_pz.family import EnvFamily
from ns_pz.params import Params

__all__ = ["NSClassicControlWrapper"]


class NSClassicControlWrapper(ScalarWrapper):
    """CartPole-v1, MountainCar-v0, MountainCarContinuous-v0, Acrobot-v1 or Pendulum-v1.

    θ_0 is read from the env's attributes (``masspole``, ``LINK_LENGTH_1``, ``m``, ...), so an
    env whose constants you changed starts from them; ``goal_velocity``, CartPole's
    ``kinematics_integrator`` and Acrobot's ``torque_noise_max`` are honoured too, and any other
    setting that differs from the default is refused (:mod:`ns_pz.compat.settings`). A change
    that would leave the physical range (a negative mass) is projected onto it (NS-Gym rejects
    the change with a warning).
    """

    _accepts = "a classic-control env (gymnasium.make('CartPole-v1'), ...)"

    def _binding(self, env: gym.Env[Any, Any]) -> Binding:
        binding = CLASSIC_CONTROL.get(env_class_name(env))
        if binding is None:
            raise self._unsupported(env, list(CLASSIC_CONTROL))
        return binding

    def _family_and_params(
        self, env: gym.Env[Any, Any], binding: Binding, settings: dict[str, Any]
    ) -> tuple[EnvFamily, Params]:
        family = binding.family_class()(**settings)
        return family, family.params_cls.from_mapping(classic_control_params(binding, env))
