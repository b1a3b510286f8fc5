"""Pictures of MuJoCo states, drawn by Gymnasium's MuJoCo renderer (an OpenGL context).

The painter builds the task's Gymnasium env once in ``rgb_array`` mode (480 x 480, the task's
own camera), puts a state's integration state into its ``MjData``, runs ``mj_forward`` and lets
Gymnasium draw it. θ is not drawn (masses, damping and friction have no picture; a tilted gravity
does not tilt the floor).

MuJoCo picks its OpenGL backend from the ``MUJOCO_GL`` environment variable, read when
``mujoco`` is first imported. On a machine without a display set ``MUJOCO_GL=egl`` (software
rendering through Mesa: the Debian/Ubuntu packages ``libegl1`` and ``libgl1-mesa-dri``) or
``MUJOCO_GL=osmesa`` (package ``libosmesa6``) before anything imports ``mujoco``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from gymnasium.error import DependencyNotInstalled

if TYPE_CHECKING:
    from ns_pz.envs.mujoco_family import MujocoFamily

    from ns_pz.params import Params

GL_HINT = (
    "MuJoCo's renderer needs an OpenGL context: with a display, nothing to do; without one, set "
    "MUJOCO_GL=egl (apt-get install libegl1 libgl1-mesa-dri) or MUJOCO_GL=osmesa (apt-get "
    "install libosmesa6) before mujoco is imported"
)
"""What the error says when no OpenGL context can be made."""


class MujocoPainter:
    """Draws states of one MuJoCo family with Gymnasium's renderer for its task.

    Args:
        family: The family whose states are drawn (its Gymnasium class and state layout).
    """

    def __init__(self, family: MujocoFamily) -> None:
        module, _, name = family.gymnasium_env.partition(":")
        self._env = getattr(importlib.import_module(module), name)(render_mode="rgb_array")
        self._size = family.layout.integration

    def frame(self, state: bytes, theta: Params, last_action: Any) -> np.ndarray:
        """The picture of ``state``: ``uint8`` ``[480, 480, 3]`` (θ and the action not drawn).

        Raises:
            DependencyNotInstalled: No OpenGL context could be made (the message says what to
                install and set).
        """
        env = self._env
        integration = np.frombuffer(state, count=self._size)
        mujoco.mj_setState(env.model, env.data, integration, mujoco.mjtState.mjSTATE_INTEGRATION)
        mujoco.mj_forward(env.model, env.data)
        try:
            return np.asarray(env.render(), dtype=np.uint8)
        except Exception as error:  # noqa: BLE001 - every backend fails in its own way
            raise DependencyNotInstalled(f"{GL_HINT} ({type(error).__name__}: {error})") from None

    def text(self, state: bytes, theta: Params, last_action: Any) -> str:
        """Not drawn as text (MuJoCo families declare no ``"ansi"`` mode)."""
        raise NotImplementedError("MuJoCo states are drawn as frames, not text")

    def close(self) -> None:
        """Release the OpenGL context."""
        self._env.close()
