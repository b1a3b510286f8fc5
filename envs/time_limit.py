"""One time limit for a view made by ``gymnasium.make``: the view's own clock.

``gymnasium.make(id, max_episode_steps=N)`` wraps every environment in Gymnasium's ``TimeLimit``
(``N`` defaults to the registered limit; ``-1`` means none). A Gymnasium ``TimeLimit`` counts steps
outside the view, so copies cut from the view (``get_planning_env()``, ``branch()``) would not
know the limit and would never truncate. Every ns_pz id is therefore registered with
:class:`ViewTimeLimit` as an additional wrapper: Gymnasium applies it right after its
``TimeLimit``, and it hands that limit to the view's own clock and leaves the ``TimeLimit`` out
of the stack. The view then truncates by itself, exactly as one built by
:func:`~ns_pz.envs.registry.make_gym` does, and its copies continue the same clock.
``env.spec.max_episode_steps`` still reports the limit, and ``gymnasium.make(env.spec)`` rebuilds
the same stack. Gymnasium 1.0 to 1.4 apply additional wrappers after ``TimeLimit`` and keep its
limit in ``TimeLimit._max_episode_steps``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import EnvSpec, WrapperSpec
from gymnasium.wrappers import TimeLimit

from ns_pz.views import NSGymEnv


class ViewTimeLimit(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """Moves a Gymnasium ``TimeLimit`` directly beneath into the ns_pz view's own clock.

    Args:
        env: What ``gymnasium.make`` built so far: a ``TimeLimit`` over the view's stack, or
            the stack alone (``max_episode_steps=-1``: then the view never truncates).

    Raises:
        TypeError: The innermost environment is not an ns_pz view.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        limit = None
        if isinstance(env, TimeLimit):
            limit = env._max_episode_steps
            env = env.env
        view = env.unwrapped
        if not isinstance(view, NSGymEnv):
            raise TypeError(f"ViewTimeLimit wraps ns_pz views only, got {view!r}")
        view.process.max_episode_steps = limit
        gym.Wrapper.__init__(self, env)

    @property
    def spec(self) -> EnvSpec | None:  # type: ignore[override]  # a property in Wrapper
        """The stack's spec, with the view's limit as ``max_episode_steps``."""
        if self._cached_spec is None:
            spec = gym.Wrapper.spec.fget(self)  # type: ignore[attr-defined]
            if spec is not None:  # a copy of its own (Gymnasium deep-copies it)
                spec.max_episode_steps = self.unwrapped.max_episode_steps  # type: ignore[attr-defined]
        return self._cached_spec


WRAPPER_SPEC = WrapperSpec(
    name=ViewTimeLimit.class_name(),
    entry_point=f"{ViewTimeLimit.__module__}:{ViewTimeLimit.__name__}",
    kwargs={},
)
"""What the registry gives ``gymnasium.register`` as ``additional_wrappers``."""
