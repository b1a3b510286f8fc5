"""Stable-Baselines3's ``VecEnv`` over :class:`ns_pz.vector.NSVectorEnv`, with no per-env loop.

SB3 does not take Gymnasium vector envs; its own ``make_vec_env`` wraps N single envs in a
``DummyVecEnv`` that steps them one by one. :class:`SB3VecEnv` hands SB3 the batched env
directly: ``step_wait`` is one batched step (``SAME_STEP`` autoreset, SB3's convention), and
only the sub-envs whose episode just ended get a ``terminal_observation`` and
``TimeLimit.truncated`` in their info dict.

Needs ``stable-baselines3`` (the ``learn`` extra), imported when this module is; without it the
import raises :class:`~ns_pz.errors.MissingExtra` saying so.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

from ns_pz.extras import require
from ns_pz.vector import NSVectorEnv

VecEnv = require("stable_baselines3.common.vec_env.base_vec_env", "ns_pz.learning.sb3_vec").VecEnv


class SB3VecEnv(VecEnv):  # type: ignore[misc]  # SB3 is untyped here
    """An SB3 ``VecEnv`` stepping an :class:`NSVectorEnv` in one batched call.

    Args:
        env: The vector env; it must use ``AutoresetMode.SAME_STEP``
            (``ns_pz.envs.registry.make_vec(id, N, autoreset_mode="SameStep")``).

    Raises:
        TypeError: ``env`` is not an :class:`NSVectorEnv`.
        ValueError: It does not reset in the same step.
    """

    def __init__(self, env: NSVectorEnv) -> None:
        if not isinstance(env, NSVectorEnv):
            raise TypeError(f"env={env!r} must be an ns_pz NSVectorEnv")
        if env.autoreset_mode is not AutoresetMode.SAME_STEP:
            raise ValueError(
                f"env uses autoreset_mode={env.autoreset_mode!r}; SB3 needs "
                "AutoresetMode.SAME_STEP (make_vec(..., autoreset_mode='SameStep'))"
            )
        self.env = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: Any = None

    def reset(self) -> dict[str, np.ndarray]:
        """Reset every sub-env, with the seeds and options given to ``seed``/``set_options``.

        Raises:
            ValueError: :meth:`set_options` gave the sub-envs different options: they reset
                together, with one ``options`` for all.
        """
        seeds = self._seeds if any(s is not None for s in self._seeds) else None
        given = [options for options in self._options if options]
        if given and (len(given) < self.num_envs or any(o != given[0] for o in given)):
            raise ValueError(
                f"set_options gave the sub-envs different options ({self._options!r}); "
                "SB3VecEnv resets them together, with the same options for all"
            )
        obs, _ = self.env.reset(seed=seeds, options=given[0] if given else None)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store the batch of actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[dict]]:
        """One batched step; ended sub-envs are already reset in the returned observation."""
        obs, rewards, terminated, truncated, infos = self.env.step(self._actions)
        dones = terminated | truncated
        out: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if infos:
            final = infos["final_obs"]
            for i in np.flatnonzero(dones):
                out[i]["terminal_observation"] = final[i]
                out[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, out

    def close(self) -> None:
        """Nothing to release."""

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The vector env's attribute, once per selected sub-env (there are no sub-env objects).

        Raises:
            AttributeError: The vector env has no such attribute (the message says where the
                per-sub-env θ is).
        """
        try:
            value = getattr(self.env, attr_name)
        except AttributeError:
            raise AttributeError(
                f"get_attr({attr_name!r}): SB3VecEnv steps one batched NSVectorEnv, which has no "
                f"attribute {attr_name!r} (per-sub-env θ: venv.env.thetas(); its settings: "
                "venv.env.family, venv.env.num_envs, ...)"
            ) from None
        return [value] * len(list(self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Refused: the sub-envs share one batched env.

        Raises:
            NotImplementedError: Always.
        """
        raise NotImplementedError(f"set_attr({attr_name!r}) is not supported by SB3VecEnv")

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Refused: the sub-envs share one batched env.

        Raises:
            NotImplementedError: Always.
        """
        raise NotImplementedError(f"env_method({method_name!r}) is not supported by SB3VecEnv")

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """No sub-env is wrapped."""
        return [False] * len(list(self._get_indices(indices)))

    def get_images(self) -> Sequence[np.ndarray | None]:
        """No rendering."""
        return [None] * self.num_envs
