"""The Gymnasium view: the NS-MDP game collapsed into a single-agent ``gymnasium.Env``.

Nature and the monitor are fixed policies inside the environment; the decision agent is the
Gymnasium agent. Observations are the flat ``Dict`` described in :mod:`ns_pz.observations`; the
reward is the base environment's, a plain float. ``info`` is the base environment's (``{}`` but
for families that keep one, such as the MuJoCo tasks' reward terms): the true θ is never given
to an agent unless asked for, through :meth:`NSGymEnv.ground_truth` or
``ground_truth_info=True`` (which adds ``info["theta"]``, a dict of the θ the transition just
made ran under; θ_0 at reset).

The view drives the same :class:`~ns_pz.process.NSProcess` as the AEC game, through the same
turns in the same order (:meth:`~ns_pz.process.NSProcess.play_until` plays nature and the monitor
at reset and after every transition), without the game's per-agent bookkeeping: it yields the
same trajectories, notifications included, for any nature and monitor, at a fraction of the cost.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym

from ns_pz.checks import flag
from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import Monitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.policies import Nature
from ns_pz.observations import agent_observation_space
from ns_pz.params import Params
from ns_pz.process import DECISION, GroundTruth, NSProcess, check_seed
from ns_pz.rendering import Renderer, render_metadata


class ProcessEnv:
    """What every single-agent env over a process shares: rendering it and the ground-truth info.

    The Gymnasium view and the learner seats' envs (:mod:`ns_pz.learning.seats`) set ``_process``,
    ``_renderer`` and ``_ground_truth_info``.
    """

    _process: NSProcess
    _renderer: Renderer
    _ground_truth_info: bool

    def render(self) -> Any:
        """The current state in ``render_mode``: a frame, text, or ``None`` (human, none).

        Raises:
            ResetNeeded: Called before the first reset.
        """
        return self._renderer.render(self._process)

    def close(self) -> None:
        """Close the render window, if one is open."""
        self._renderer.close()

    def _info(self) -> dict[str, Any]:
        """``info``: the base environment's, and the θ of the last transition if asked for.

        The θ comes with ``ground_truth_info=True`` only.
        """
        process = self._process
        info = process.family.info(process.state) if process.family.has_info else {}
        if self._ground_truth_info:
            info["theta"] = process.last_theta.as_dict()
        return info


class NSGymEnv(ProcessEnv, gym.Env[dict[str, Any], Any]):
    """A non-stationary environment as an ordinary Gymnasium env.

    Args:
        family: The environment family (dynamics and θ).
        params: θ_0, as a parameter set or a mapping of names to values.
        nature: Who changes θ, e.g. ``ScriptedNature({"masspole": IncrementUpdate(...)})``.
            Default: nobody (stationary).
        monitor: Who decides the notification. Default: :class:`~ns_pz.monitor.OracleMonitor`.
        notification: ``"none"``, ``"basic"`` or ``"detailed"``.
        constraints: Lipschitz bound and budget on nature.
        max_episode_steps: Transitions after which an episode is truncated.
        ground_truth_info: Put the θ of the last transition into ``info["theta"]`` (for
            evaluation only).
        render_mode: ``None``, or one of the family's modes (``"human"``, ``"rgb_array"``, and
            ``"ansi"`` for grid worlds); see :mod:`ns_pz.rendering`.

    Raises:
        ValueError: ``render_mode`` is not one of the family's modes.
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        family: EnvFamily,
        *,
        params: Params | Mapping[str, Any] | None = None,
        nature: Nature | None = None,
        monitor: Monitor | None = None,
        notification: str | NotificationLevel = "none",
        constraints: NatureConstraints | None = None,
        max_episode_steps: int | None = 500,
        ground_truth_info: bool = False,
        render_mode: str | None = None,
    ) -> None:
        self._process = NSProcess(
            family,
            params=params,
            nature=nature,
            monitor=monitor,
            notification=notification,
            constraints=constraints,
            max_episode_steps=max_episode_steps,
        )
        self._ground_truth_info = flag("ground_truth_info", ground_truth_info)
        self._renderer = Renderer(family, render_mode)
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, **render_metadata(family)}
        self.observation_space = agent_observation_space(family)
        self.action_space = family.action_space

    # -- Gymnasium API ----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode; a seed reseeds the environment, nature, monitor and planning.

        Args:
            seed: A non-negative int, or ``None`` to go on with the current generators.
            options: ``{"params": θ_0}`` starts this episode from another θ_0 (a parameter set
                or a mapping of names to values); other keys are ignored with a warning.

        Raises:
            TypeError / ValueError: A bad seed or θ_0, options that are no mapping, or a θ_0
                the monitor cannot serve (a detector bound to another); nothing changes then.
        """
        process = reset_seeded(self, self._process, seed, options)
        process.play_until(DECISION)
        if self.render_mode == "human":
            self.render()
        return process.agent_observation(), self._info()

    def step(self, action: Any) -> tuple[dict[str, Any], SupportsFloat, bool, bool, dict[str, Any]]:
        """The transition under θ_t, then nature's and the monitor's turns of the next step."""
        reward, terminated, truncated = self._advance(action)
        return (
            self._process.agent_observation(),
            float(reward),
            bool(terminated),
            bool(truncated),
            self._info(),
        )

    # -- ns_pz extras -----------------------------------------------------------------------
    @property
    def family(self) -> EnvFamily:
        """The environment family."""
        return self._process.family

    @property
    def notification_level(self) -> NotificationLevel:
        """What the agent is told about changes."""
        return self._process.level

    @property
    def max_episode_steps(self) -> int | None:
        """Transitions after which an episode is truncated (``None``: never)."""
        return self._process.max_episode_steps

    @property
    def base_params(self) -> Params:
        """θ_0 of this episode: the environment's, or the one ``reset(options=...)`` gave it."""
        return self._process.theta0

    def set_params(self, **changes: Any) -> None:
        """Change the θ in force now, by hand (validated; applies to the next transition).

        Raises:
            ResetNeeded: No episode is running.
            UnknownParam: A name is not a parameter.
            ParamOutOfRange: A value is invalid.
        """
        self._process.check_running("set_params()")
        self._process.set_params(changes)

    def ground_truth(self) -> GroundTruth:
        """The true θ_0, current θ and change times of this episode (for evaluation)."""
        return self._process.ground_truth()

    def planning_model(self) -> Any:
        """A stationary planning model at the current state under the planning θ.

        That θ is θ_0 at ``none`` and ``basic``; at ``detailed`` the latest θ the agent has been
        told of (:meth:`~ns_pz.process.NSProcess.planning_theta`).

        Raises:
            ResetNeeded: Called before the first reset.
        """
        return self._process.planning_model()

    def get_planning_env(self) -> NSGymEnv:
        """A stationary copy of this env at the current state, as a Gymnasium env.

        Its θ is the planning θ (:meth:`planning_model`'s): θ_0 at notification levels ``none``
        and ``basic``; at ``detailed`` the latest θ the agent has been told of (with the oracle,
        that of the last transition, never the one nature just chose for the next); nature is
        frozen in it, so stepping it never changes θ. It continues the
        clock (``relative_time``) and the time limit of this episode, and draws from its own
        generator, derived from this env's seed.

        Raises:
            ResetNeeded: Called before the first reset.
        """
        return self.branch()

    def branch(
        self, *, theta: Params | None = None, keep_nature: bool = False, retake_turn: bool = False
    ) -> NSGymEnv:
        """A copy of this env at the current state and time, on its own generators.

        Args:
            theta: The θ of the copy; default what :meth:`get_planning_env` uses (the
                planning θ: θ_0, or at ``detailed`` the latest θ the agent has been told of).
            keep_nature: Let nature go on acting in the copy (from where its schedule is now)
                instead of freezing θ.
            retake_turn: With ``keep_nature``, nature moves again in the copy at the current
                step, from ``theta`` (see :meth:`~ns_pz.process.NSProcess.continuing_copy`).

        Raises:
            ResetNeeded: Called before the first reset.
            TypeError: ``theta`` is not a parameter set of this family, or a flag not a bool.
            ValueError: ``retake_turn`` without ``keep_nature``.
        """
        process = self._process
        params_cls = process.family.params_cls
        if theta is not None and not isinstance(theta, params_cls):
            raise TypeError(
                f"theta={theta!r} must be a {params_cls.__name__} (e.g. "
                "env.process.theta.replace(name=value)) or None"
            )
        flag("keep_nature", keep_nature)
        flag("retake_turn", retake_turn)
        if retake_turn and not keep_nature:
            raise ValueError("retake_turn=True needs keep_nature=True (frozen, nature never moves)")
        twin = copy.copy(self)
        if keep_nature:
            twin._process = process.continuing_copy(theta, retake_turn=retake_turn)
        else:
            twin._process = process.stationary_copy(theta)
        twin._np_random = twin._process.env_rng
        twin._renderer = self._renderer.branch()
        twin.render_mode = twin._renderer.mode
        return twin

    @property
    def process(self) -> NSProcess:
        """The process this view drives (for adapters such as :mod:`ns_pz.compat`)."""
        return self._process

    # -- internals --------------------------------------------------------------------------
    def _advance(self, action: Any) -> tuple[Any, Any, bool]:
        """:meth:`step` without the observation (adapters that build their own call this).

        Returns:
            ``(reward, terminated, truncated)`` of the transition.
        """
        process = self._process
        if process.done:
            process.check_running("step()")
        outcome = process.transition(process.family.check_action(action))
        if not process.done:
            process.play_until(DECISION)
        if self.render_mode == "human":
            self.render()
        return outcome

    def __repr__(self) -> str:
        process = self._process
        return (
            f"NSGymEnv({process.family!r}, nature={process.nature!r}, "
            f"notification={process.level.value!r})"
        )


def reset_seeded(
    env: gym.Env[Any, Any], process: NSProcess, seed: int | None, options: dict[str, Any] | None
) -> NSProcess:
    """Gymnasium's reset of ``env`` (``np_random`` from ``seed``), then a new episode.

    A seed reseeds every generator of the process, and the env's ``np_random`` becomes the
    process's environment generator (what Gymnasium's checker compares); without a seed the
    generators go on.

    Raises:
        TypeError / ValueError: A bad seed, θ_0 or options (refused before anything changes).
    """
    seed = check_seed(seed)  # a NumPy integer becomes an int, which Gymnasium insists on
    prepared = process.prepare_episode(options)
    gym.Env.reset(env, seed=seed)
    if seed is not None or process.env_rng is None:
        process.seed(env.np_random_seed)
        env._np_random = process.env_rng
    process.reset(options, prepared=prepared)
    return process
