"""Rendering for the Gymnasium view and the AEC game: modes, checks and the human window.

Each family declares the modes it can draw (``EnvFamily.render_modes``) and hands out a
*painter* (``EnvFamily.painter()``, drawings in :mod:`ns_pz.envs.rendering`) that pictures one
state under one θ:

* ``"rgb_array"``: a ``uint8`` frame ``[height, width, 3]``;
* ``"ansi"``: text with ANSI colour codes (the grid worlds);
* ``"human"``: the ``"rgb_array"`` frame shown in a pygame window at the family's
  ``render_fps``, redrawn after every reset and transition; :meth:`Renderer.render` returns
  ``None``.

pygame is optional (``pip install "ns_pz[render]"``): the window needs it, and so do the
classic-control frames, which Gymnasium's own renderers draw. The grid worlds draw their
frames and text with NumPy alone.
"""

from __future__ import annotations

import importlib.util
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from gymnasium.error import DependencyNotInstalled

from ns_pz.errors import ResetNeeded

if TYPE_CHECKING:
    from ns_pz.family import EnvFamily
    from ns_pz.params import Params
    from ns_pz.process import NSProcess

RENDER_MODES = ("human", "rgb_array", "ansi")
"""Every mode any family may declare."""

PYGAME_HINT = 'pip install "ns_pz[render]" (or "gymnasium[classic-control]")'


class Painter(Protocol):
    """Draws states of one family; made by ``EnvFamily.painter()``, one per environment."""

    def frame(self, state: Any, theta: Params, last_action: Any) -> np.ndarray:
        """The picture of ``state`` under ``theta``: ``uint8`` ``[height, width, 3]``."""
        ...

    def text(self, state: Any, theta: Params, last_action: Any) -> str:
        """The picture as text (families that declare ``"ansi"`` only)."""
        ...

    def close(self) -> None:
        """Release what drawing holds (a Gymnasium env, a surface)."""
        ...


def require_pygame(what: str) -> None:
    """Raise ``DependencyNotInstalled`` naming ``what`` and the extra to install, without pygame."""
    if importlib.util.find_spec("pygame") is None:
        raise DependencyNotInstalled(f"{what} needs pygame, which is not installed: {PYGAME_HINT}")


def render_metadata(family: EnvFamily) -> dict[str, Any]:
    """``render_modes`` and ``render_fps`` of an environment over ``family``."""
    return {"render_modes": list(family.render_modes), "render_fps": family.render_fps}


class Renderer:
    """Renders the current state of a process in one mode; one per environment instance.

    Args:
        family: The environment family (it declares the modes and draws).
        render_mode: ``None`` (no rendering) or one of ``family.render_modes``.

    Raises:
        ValueError: ``render_mode`` is not one the family supports (the message lists them).
        DependencyNotInstalled: The mode needs pygame and pygame is missing.
    """

    def __init__(self, family: EnvFamily, render_mode: str | None) -> None:
        allowed = tuple(family.render_modes)
        if render_mode is not None and (
            not isinstance(render_mode, str) or render_mode not in allowed
        ):
            raise ValueError(
                f"render_mode={render_mode!r} is not supported by {family!r}; "
                f"allowed: {[None, *allowed]}"
            )
        self.family = family
        self.mode = render_mode
        self._painter: Painter | None = None
        self._window: HumanWindow | None = None
        if render_mode == "human":
            require_pygame("render_mode='human' (a pygame window)")
        if render_mode is not None:
            self._painter = family.painter()

    def render(self, process: NSProcess) -> np.ndarray | str | None:
        """Draw the process's current state under the θ in force (``None`` in human mode).

        Raises:
            ResetNeeded: No episode has started yet.
        """
        if self._painter is None:
            return None
        if not process.started:
            raise ResetNeeded("render() called before reset(); call reset() first")
        state, theta, action = process.state, process.theta, process.last_action
        if self.mode == "ansi":
            return self._painter.text(state, theta, action)
        frame = self._painter.frame(state, theta, action)
        if self.mode == "rgb_array":
            return frame
        if self._window is None:
            self._window = HumanWindow(repr(self.family), self.family.render_fps)
        self._window.show(frame)
        return None

    def branch(self) -> Renderer:
        """A renderer for a copy of the environment: same mode, but no window of its own.

        A copy made for planning must not draw into the user's window at every simulated
        step, so a ``"human"`` renderer branches into one that renders nothing.
        """
        return Renderer(self.family, None if self.mode == "human" else self.mode)

    def close(self) -> None:
        """Close the window and release the painter."""
        if self._window is not None:
            self._window.close()
            self._window = None
        if self._painter is not None:
            self._painter.close()


class HumanWindow:
    """A pygame window showing RGB frames at a fixed rate (what ``"human"`` mode draws into).

    Args:
        title: The window's caption.
        fps: Frames per second; :meth:`show` waits so as not to exceed it.
    """

    def __init__(self, title: str, fps: float) -> None:
        self.title = title
        self.fps = fps
        self._screen: Any = None
        self._clock: Any = None

    def show(self, frame: np.ndarray) -> None:
        """Display ``frame`` (``uint8`` ``[height, width, 3]``), opening the window first."""
        import pygame

        height, width = frame.shape[:2]
        if self._screen is None or self._screen.get_size() != (width, height):
            pygame.display.init()
            pygame.display.set_caption(self.title)
            self._screen = pygame.display.set_mode((width, height))
            self._clock = pygame.time.Clock()
        surface = pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2)))
        self._screen.blit(surface, (0, 0))
        pygame.event.pump()
        self._clock.tick(self.fps)
        pygame.display.flip()

    def close(self) -> None:
        """Close the window (if it was opened)."""
        if self._screen is not None:
            import pygame

            pygame.display.quit()
            self._screen = None
