"""Environment families: a θ, spaces, and dynamics written as functions of θ.

A family holds what never changes within an environment (spaces, a map, outcome tables) and
exposes dynamics in the style ``step(state, action, theta, rng) -> (next_state, reward,
terminal)``. θ is an argument, never an attribute, so a change of θ can never be half-applied,
and derived quantities (a total mass, a transition table) are computed from the θ handed in.

States are small immutable values (an ``int`` for grid worlds, a tuple of floats for physics),
so saving and restoring a simulator is copying a reference.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from gymnasium import spaces

from ns_pz.params import Params

if TYPE_CHECKING:
    from ns_pz.rendering import Painter

State = Any
"""A simulator state: a small immutable value (an ``int`` cell, a tuple of floats)."""


class EnvFamily(ABC):
    """Base of every environment family.

    Subclasses set :attr:`params_cls`, build :attr:`observation_space` and :attr:`action_space`
    in ``__init__`` (constructor arguments fix the spaces; θ never changes them) and implement
    the dynamics.
    """

    params_cls: ClassVar[type[Params]]
    observation_space: spaces.Space[Any]
    action_space: spaces.Space[Any]
    render_modes: ClassVar[tuple[str, ...]] = ()
    """Render modes the family can draw (see :mod:`ns_pz.rendering`)."""
    render_fps: ClassVar[int] = 30
    """Frames per second of ``"human"`` rendering and of recorded videos."""
    has_info: ClassVar[bool] = False
    """Whether :meth:`info` says anything (the views skip the call otherwise)."""
    deterministic_step: ClassVar[bool] = False
    """Whether :meth:`step` never draws from its generator, so that its outcome is a function
    of ``(state, action, θ)``: a caller may then play once what it would play several times
    alike (DDQN-WN's scoring episodes). Only set it for a step that leaves ``rng`` untouched
    (``tests/test_envs.py`` checks the built-in families that set it); a subclass whose step
    draws (noise added to a deterministic family) must set it back to False."""
    _int_actions: tuple[Any, int, int]
    """The action space and the ints it holds (set by :meth:`check_action` on first use; a
    space is replaced, never changed in place, as Gymnasium's spaces are treated)."""

    def default_params(self) -> Params:
        """θ with every parameter at its default."""
        return self.params_cls()

    @abstractmethod
    def initial_state(self, rng: np.random.Generator) -> State:
        """Draw a start state."""

    def initial_state_under(self, theta: Params, rng: np.random.Generator) -> State:
        """Draw a start state for an episode that starts under ``theta`` (θ_0).

        The same as :meth:`initial_state` unless a family's start depends on θ (a MuJoCo
        task whose first observation reads inertias); what the game and the view call.
        """
        return self.initial_state(rng)

    @abstractmethod
    def step(
        self, state: State, action: Any, theta: Params, rng: np.random.Generator
    ) -> tuple[State, float, bool]:
        """One transition under ``theta``: next state, reward, whether it is terminal."""

    @abstractmethod
    def observe(self, state: State) -> Any:
        """The observation of ``state``, an element of :attr:`observation_space`."""

    def info(self, state: State) -> dict[str, Any]:
        """The base environment's ``info`` for ``state``, a new dict.

        Families with :attr:`has_info` keep it in the state (the MuJoCo tasks' reward terms).
        """
        return {}

    def check_action(self, action: Any) -> Any:
        """Return ``action`` in canonical form, or raise ``ValueError`` if it is not allowed."""
        space = self.action_space
        if type(action) is int:  # the usual discrete action: compared with Python ints
            known = self.__dict__.get("_int_actions")
            if known is None or known[0] is not space:
                known = self._int_actions = _int_range(space)
            if known[1] <= action < known[2]:
                return action
        if isinstance(space, spaces.Discrete):
            if isinstance(action, (np.integer, np.ndarray)) and space.contains(action):
                return int(action)
        elif space.contains(np.asarray(action, dtype=space.dtype)):
            return np.array(action, dtype=space.dtype)  # our own copy: it becomes last_action
        raise ValueError(f"action={action!r} is outside the action space {space}")

    def check_state(self, state: Any) -> State:
        """Return ``state`` in canonical form, or raise ``ValueError`` if it is not a state.

        What :meth:`PlanningModel.set_state <ns_pz.planning.PlanningModel.set_state>` accepts.
        Families override it with an exact check; this fallback accepts any value whose
        observation lies in :attr:`observation_space`.
        """
        from ns_pz.states import check_observable_state

        return check_observable_state(self, state)

    def painter(self) -> Painter:
        """A new painter of this family's states, for the modes in :attr:`render_modes`.

        Raises:
            NotImplementedError: The family draws nothing (no render modes).
        """
        raise NotImplementedError(f"{self!r} draws nothing: its render_modes are empty")

    def planning_model(self, theta: Params, state: State, rng: np.random.Generator) -> Any:
        """A stationary model under ``theta`` positioned at ``state``."""
        from ns_pz.planning import PlanningModel

        return PlanningModel(self, theta, state, rng)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def _int_range(space: Any) -> tuple[Any, int, int]:
    """``(space, first, stop)``: the Python ints a ``Discrete`` space holds (none otherwise).

    NumPy's ``start`` and ``n`` make every comparison with an int several times slower.
    """
    if isinstance(space, spaces.Discrete):
        return space, int(space.start), int(space.start + space.n)
    return space, 0, 0
