"""Pictures of the families' states: grid worlds drawn with NumPy, classic control by Gymnasium.

Grid worlds (:class:`GridPainter`, no extra dependency): ``rgb_array`` frames of 32 x 32 pixel
cells coloured by map letter (start, frozen/free, hole, goal, cliff) with the agent as a red
disc; ``ansi`` text of the map with the agent's cell highlighted, under the last action's name.
θ (the slip vector) is not drawn: nothing on the map shows it.

Classic control (:class:`GymnasiumPainter`, needs pygame): the matching Gymnasium environment,
built once in ``rgb_array`` mode, is posed at the state and draws it with its own renderer, so
the pictures are Gymnasium's. What each picture shows of θ:

* CartPole: the pole is drawn ``2 * θ.length`` long (the cart and the track are fixed);
* Acrobot: the links are drawn ``θ.link_length_1`` and ``θ.link_length_2`` long;
* Pendulum: nothing of θ (Gymnasium draws a rod of fixed length); the arrow is the last
  torque, clipped to ±2;
* MountainCar and MountainCarContinuous: nothing of θ (gravity and engine power have no
  picture); the car's position on the hill and the goal flag.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.rendering import require_pygame

if TYPE_CHECKING:
    from ns_pz.envs.grid import SlipGridFamily

    from ns_pz.params import Params

CELL = 32
"""Side of a grid cell in pixels (a multiple of 16, so video encoders take frames unscaled)."""

CELL_COLOURS = {
    "S": (176, 214, 245),  # start
    "F": (232, 242, 250),  # frozen / free
    "H": (38, 56, 104),  # hole
    "G": (96, 186, 96),  # goal
    "C": (128, 82, 52),  # cliff
}
UNKNOWN_CELL = (200, 200, 200)
GRID_LINE = (150, 160, 170)
AGENT = (214, 48, 40)
MOVE_NAMES = {(0, -1): "Left", (1, 0): "Down", (0, 1): "Right", (-1, 0): "Up"}
_HIGHLIGHT = "\x1b[41m{}\x1b[0m"  # ANSI red background


class GridPainter:
    """Draws a slip-grid family's cells and agent.

    Args:
        family: The grid family (its map ``desc`` and ``moves``).
    """

    def __init__(self, family: SlipGridFamily) -> None:
        self.family = family
        self._background = _grid_background(family.desc)
        centre = (CELL - 1) / 2
        rows, cols = np.mgrid[0:CELL, 0:CELL]
        self._disc = (rows - centre) ** 2 + (cols - centre) ** 2 <= (0.32 * CELL) ** 2
        self._move_names = tuple(MOVE_NAMES.get(tuple(m), str(m)) for m in family.moves)

    def frame(self, state: int, theta: Params, last_action: Any) -> np.ndarray:
        """The map with the agent in cell ``state``: ``uint8`` ``[nrow * 32, ncol * 32, 3]``."""
        frame = self._background.copy()
        row, col = divmod(int(state), self.family.ncol)
        cell = frame[row * CELL : (row + 1) * CELL, col * CELL : (col + 1) * CELL]
        cell[self._disc] = AGENT
        return frame

    def text(self, state: int, theta: Params, last_action: Any) -> str:
        """The map, one line per row, the agent's cell highlighted; the last action above it."""
        row, col = divmod(int(state), self.family.ncol)
        lines = [f"  ({self._move_names[int(last_action)]})"] if last_action is not None else []
        for r, letters in enumerate(self.family.desc):
            if r == row:
                letters = letters[:col] + _HIGHLIGHT.format(letters[col]) + letters[col + 1 :]
            lines.append(letters)
        return "\n".join(lines) + "\n"

    def close(self) -> None:
        """Nothing to release."""


def _grid_background(desc: tuple[str, ...]) -> np.ndarray:
    """The map's cells as colour blocks with one-pixel lines between them (read-only)."""
    letters = np.array([list(row) for row in desc])
    colours = np.array(
        [[CELL_COLOURS.get(letter, UNKNOWN_CELL) for letter in row] for row in letters],
        dtype=np.uint8,
    )
    frame = np.repeat(np.repeat(colours, CELL, axis=0), CELL, axis=1)
    frame[::CELL, :] = GRID_LINE
    frame[:, ::CELL] = GRID_LINE
    frame.flags.writeable = False
    return frame


Pose = Callable[[Any, Any, Any, Any], None]
"""``pose(gymnasium_env, state, theta, last_action)``: set what the Gymnasium renderer reads."""


class GymnasiumPainter:
    """Draws a classic-control state with Gymnasium's own renderer.

    Args:
        env_class: Name of the Gymnasium class in ``gymnasium.envs.classic_control``.
        pose: Sets the Gymnasium env's state (and θ-dependent attributes) before it draws.

    Raises:
        DependencyNotInstalled: pygame is missing.
    """

    def __init__(self, env_class: str, pose: Pose) -> None:
        require_pygame(f"Drawing {env_class} frames (Gymnasium's renderer)")
        from gymnasium.envs import classic_control

        self._env = getattr(classic_control, env_class)(render_mode="rgb_array")
        self._pose = pose

    def frame(self, state: Any, theta: Params, last_action: Any) -> np.ndarray:
        """Gymnasium's picture of ``state``: ``uint8`` ``[height, width, 3]``."""
        self._pose(self._env, state, theta, last_action)
        return self._env.render()  # type: ignore[no-any-return]

    def text(self, state: Any, theta: Params, last_action: Any) -> str:
        """Classic-control families have no text picture."""
        raise NotImplementedError("classic-control families render no 'ansi' text")

    def close(self) -> None:
        """Close the Gymnasium env (its pygame surface)."""
        self._env.close()


def pose_cartpole(env: Any, state: Any, theta: Any, last_action: Any) -> None:
    """Cart and pole from the state; the pole's half-length from θ."""
    env.state = np.array(state, dtype=np.float64)
    env.length = theta.length


def pose_mountain_car(env: Any, state: Any, theta: Any, last_action: Any) -> None:
    """The car's position and velocity (the continuous family's float32 flag is dropped)."""
    env.state = np.array(state[:2], dtype=np.float64)


def pose_pendulum(env: Any, state: Any, theta: Any, last_action: Any) -> None:
    """Angle and velocity; the last torque (clipped to ±2, as the dynamics use it) as the arrow."""
    env.state = np.array(state, dtype=np.float64)
    env.last_u = None if last_action is None else float(np.clip(last_action[0], -2.0, 2.0))


def pose_acrobot(env: Any, state: Any, theta: Any, last_action: Any) -> None:
    """Joint angles from the state; link lengths from θ."""
    env.state = np.array(state, dtype=np.float64)
    env.LINK_LENGTH_1 = theta.link_length_1
    env.LINK_LENGTH_2 = theta.link_length_2
