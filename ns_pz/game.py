"""The NS-MDP as a PettingZoo AEC game: nature, then the monitor, then the decision agent.

Each time step ``t``:

1. ``nature`` observes its encoding of ``(t, θ_{t-1} against θ_0, budgets left)`` (and, with
   ``nature_observes_state=True``, the agent's state and last action; see
   :mod:`ns_pz.nature.interface`) and acts: with Δθ (``nature_action="delta"``, the default) or
   with ``Box(-1, 1)`` per parameter scaled to its per-step allowance (``"normalized"``); zero
   means no change. The game projects the proposal onto the allowed set (bounds, Lipschitz
   bounds, budgets): θ_t.
2. ``monitor`` observes the last transition and acts with the notification for the agent: a
   ``Dict`` of ``env_change`` flags and ``delta_change`` sizes (``monitor_action="dict"``) or the
   flags alone as ``MultiDiscrete([2] * n)`` (``"flags"``, for libraries that refuse ``Dict``
   actions), masked to the game's level.
3. ``agent`` observes the state with that notification and acts; the base environment makes one
   transition under θ_t, and every agent is rewarded: the agent gets r_t, nature -r_t
   (``nature_reward="zero_sum"``, the default), r_t (``"cooperative"``), 0 (``"none"``) or its
   regret (``"regret"``: -r_t each step, and at the end of the episode the value a reference
   earns against the same θ trajectory, see :mod:`ns_pz.regret`); the monitor 0.

The order lives in :class:`~ns_pz.process.NSProcess`, which the Gymnasium view and the learner
environments drive too. The episode ends for all three together when the base environment
terminates or the time limit truncates. :meth:`NSGame.policy_action` gives the action of the
configured nature and monitor policies (the same answer however often it is asked within a
turn), so any subset of the agents can be scripted while the others learn.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv

from ns_pz.errors import ResetNeeded
from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import Monitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.monitor.scoring import MonitorRewardFn, monitor_reward_of, monitor_reward_value
from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.policies import Nature
from ns_pz.observations import (
    agent_observation_space,
    monitor_action_space,
    monitor_flags_space,
    monitor_observation_space,
)
from ns_pz.params import Params
from ns_pz.process import (
    AGENTS,
    DECISION,
    MONITOR,
    NATURE,
    GroundTruth,
    NSProcess,
    check_seed,
)
from ns_pz.regret import NATURE_REWARDS, NatureReward, RegretReference
from ns_pz.rendering import Renderer, render_metadata

MONITOR_ACTIONS = ("dict", "flags")

__all__ = ["AGENTS", "DECISION", "MONITOR", "NATURE", "NATURE_REWARDS", "NSGame"]


class NSGame(AECEnv):
    """The NS-MDP game over one environment family.

    Args:
        family: The environment family.
        params: θ_0 (a parameter set or a mapping of names to values).
        nature: The nature :meth:`policy_action` follows (default: static).
        monitor: The monitor :meth:`policy_action` follows (default: oracle).
        notification: ``"none"``, ``"basic"`` or ``"detailed"``: what reaches the agent.
        constraints: Lipschitz bounds and budgets enforced on every nature action.
        max_episode_steps: Time steps after which all agents are truncated.
        nature_reward: ``"zero_sum"`` (-r), ``"cooperative"`` (+r), ``"none"`` (0) or
            ``"regret"`` (needs ``regret_reference``).
        regret_reference: What nature's regret is measured against (``"regret"`` only).
        nature_action: ``"delta"`` (Δθ) or ``"normalized"`` (``Box(-1, 1)`` per allowance).
        nature_observes_state: Add the agent's state and last action to nature's observation.
        monitor_action: ``"dict"`` (flags and sizes) or ``"flags"`` (``MultiDiscrete``).
        monitor_reward: What the monitor earns at its turn, for a learning monitor: ``None``
            (nothing, the default), ``"detection"`` (:class:`~ns_pz.monitor.DetectionReward`)
            or a function ``fn(process, flags) -> float`` of the flags just sent (as in
            :func:`~ns_pz.learning.seats.single_agent`). It is the monitor's reward of that step and
            what ``last()`` gives the monitor at its next turn. The episode's last transition,
            which no monitor turn follows, pays the monitor as silence about it, at the
            decision turn that ends the episode.
        render_mode: ``None``, or one of the family's modes (``"human"``, ``"rgb_array"``, and
            ``"ansi"`` for grid worlds): :meth:`render` draws the environment's state under the
            θ in force; ``"human"`` redraws after every reset and transition.

    Raises:
        ValueError: ``render_mode`` is not one of the family's modes, or ``monitor_reward`` is
            none of the above.
    """

    metadata: dict[str, Any] = {
        "name": "ns_pz_game",
        "is_parallelizable": False,
        "render_modes": [],
    }

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
        nature_reward: str = "zero_sum",
        regret_reference: RegretReference | None = None,
        nature_action: str = "delta",
        nature_observes_state: bool = False,
        monitor_action: str = "dict",
        monitor_reward: MonitorRewardFn | str | None = None,
        render_mode: str | None = None,
    ) -> None:
        super().__init__()
        self._process = process = NSProcess(
            family,
            params=params,
            nature=nature,
            monitor=monitor,
            notification=notification,
            constraints=constraints,
            max_episode_steps=max_episode_steps,
        )
        self._nature_reward = NatureReward(nature_reward, regret_reference)
        if monitor_action not in MONITOR_ACTIONS:
            raise ValueError(f"monitor_action={monitor_action!r}; allowed: {MONITOR_ACTIONS}")
        self._monitor_flags_only = monitor_action == "flags"
        self._monitor_reward = monitor_reward_of(monitor_reward)
        self._nature = process.nature_interface(nature_action, nature_observes_state)
        self._renderer = Renderer(family, render_mode)
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, **render_metadata(family)}
        params_cls = family.params_cls
        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        self.observation_spaces = {
            NATURE: self._nature.observation_space,
            MONITOR: monitor_observation_space(family),
            DECISION: agent_observation_space(family),
        }
        self.action_spaces: dict[str, spaces.Space[Any]] = {
            NATURE: self._nature.action_space,
            MONITOR: monitor_flags_space(params_cls)
            if self._monitor_flags_only
            else monitor_action_space(params_cls),
            DECISION: family.action_space,
        }
        self._rewarded = False
        self._scripted: tuple[np.ndarray, list, Any, int] | None = None
        """Nature's policy action handed out this turn: the array, its values then, the exact
        proposal behind it, and the step."""
        self._scripted_notice: tuple[Any, int, Any, Any, list, list] | None = None
        """The monitor policy's action handed out this turn: the object, the step, and in dict
        mode its two arrays and their values then (``None`` and empty lists in flags mode)."""
        # Before the first reset: calls meet ResetNeeded, not missing attributes.
        self.agent_selection = NATURE
        self.rewards: dict[str, float] = {}
        self._cumulative_rewards: dict[str, float] = {}
        self.terminations: dict[str, bool] = {}
        self.truncations: dict[str, bool] = {}
        self.infos: dict[str, dict[str, Any]] = {}

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The (always identical) observation space of ``agent``."""
        return self.observation_spaces[_check_agent(agent)]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The (always identical) action space of ``agent``."""
        return self.action_spaces[_check_agent(agent)]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        """Start an episode; a seed reseeds the environment, nature, monitor and planning.

        Args:
            seed: A non-negative int, or ``None`` to go on with the current generators.
            options: ``{"params": θ_0}`` starts this episode from another θ_0.

        Raises:
            TypeError / ValueError: A bad seed or θ_0, options that are no mapping, or a θ_0
                the monitor cannot serve (a detector bound to another); nothing changes then.
        """
        process = self._process
        seed = check_seed(seed)
        prepared = process.prepare_episode(options)  # refused before anything changes
        if seed is not None or process.env_rng is None:
            process.seed(seed)
        process.reset(options, prepared=prepared)
        self.agents = list(AGENTS)
        self.rewards = dict.fromkeys(AGENTS, 0.0)
        self._cumulative_rewards = dict.fromkeys(AGENTS, 0.0)
        self.terminations = dict.fromkeys(AGENTS, False)
        self.truncations = dict.fromkeys(AGENTS, False)
        self.infos = {agent: {} for agent in AGENTS}
        self.agent_selection = NATURE
        self._rewarded = False
        self._scripted = None
        self._scripted_notice = None
        reset_reward = getattr(self._monitor_reward, "reset", None)
        if callable(reset_reward):
            reset_reward()
        if self.render_mode == "human":
            self.render()

    def observe(self, agent: str) -> Any:
        """What ``agent`` sees now (see :mod:`ns_pz.observations`)."""
        process = self._process
        if not process.started:
            process.check_running("observe()")
        if agent == DECISION:
            return process.agent_observation()
        if agent == NATURE:
            return self._nature.observe(process)
        if agent == MONITOR:
            return process.build.monitor(process)
        raise ValueError(f"agent={agent!r} is not one of {AGENTS}")

    def last(self, observe: bool = True) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """PettingZoo's ``last()``; after the episode has ended for every agent it says so.

        Raises:
            ResetNeeded: Called before reset or after every agent has left.
        """
        if not self.agents:
            if not self._process.started:
                raise ResetNeeded("last() called before reset(); call reset() first")
            raise ResetNeeded("last() called after the episode ended; call reset() first")
        return super().last(observe)

    def step(self, action: Any) -> None:
        """Take the selected agent's turn."""
        agent = self.agent_selection
        if self.terminations.get(agent) or self.truncations.get(agent):
            self._was_dead_step(action)
            return
        process = self._process
        if process.done:
            process.check_running("step()")
        # Each branch validates before it changes anything, so a refused action leaves the
        # game as it was (rewards included).
        if agent == NATURE:
            scripted = self._scripted
            if (
                scripted is not None
                and action is scripted[0]
                and action.tolist() == scripted[1]
                and process.t == scripted[3]
            ):
                proposal = scripted[2]  # the policy's own values, exact
            else:
                proposal = self._nature.proposal(action, process.theta)
            process.nature_turn(proposal)
            self._scripted = None
        elif agent == MONITOR:
            if self._is_policy_notice(action):  # the policy's own notification, exact
                flags = self._scripted_notice[4]  # type: ignore[index]  # checked just now
                process.play_until(DECISION)
            else:
                flags, sizes = self._notification_of(action)
                process.monitor_turn(flags, sizes)
            self._scripted_notice = None
            if self._monitor_reward is not None:
                self._pay_monitor(monitor_reward_value(self._monitor_reward, process, tuple(flags)))
                return
        else:
            action = process.family.check_action(action)
        # Rewards arise only from the transition at the end of the decision turn; the other
        # turns just clear them and restart the acting agent's running total.
        self._cumulative_rewards[agent] = 0.0
        if agent == DECISION:
            self._decision_turn(action)
            return
        if self._rewarded:
            self.rewards = dict.fromkeys(AGENTS, 0.0)
            self._rewarded = False
        self.agent_selection = process.turn

    def _pay_monitor(self, reward: float) -> None:
        """The monitor's reward for the notification it just sent; the agent's turn follows."""
        self._cumulative_rewards[MONITOR] = reward  # what it earned since it last acted
        self.rewards = {NATURE: 0.0, MONITOR: reward, DECISION: 0.0}
        self._rewarded = True
        self.agent_selection = self._process.turn

    def _decision_turn(self, action: Any) -> None:
        process = self._process
        reward, terminated, truncated = process.transition(action)
        reward = float(reward)
        nature_reward = self._nature_reward.per_step(reward)
        if process.done:
            nature_reward += self._nature_reward.at_end(process)
        monitor_reward = 0.0
        if process.done and self._monitor_reward is not None:
            # No monitor turn follows the last transition: it is paid as silence about it.
            monitor_reward = float(self._monitor_reward(process, process.no_change))
        self.rewards = {NATURE: nature_reward, MONITOR: monitor_reward, DECISION: reward}
        self._rewarded = True
        totals = self._cumulative_rewards
        totals[NATURE] += nature_reward
        totals[MONITOR] += monitor_reward
        totals[DECISION] += reward
        if terminated or truncated:
            self.terminations = dict.fromkeys(AGENTS, bool(terminated))
            self.truncations = dict.fromkeys(AGENTS, bool(truncated))
        self.agent_selection = NATURE
        if self.render_mode == "human":
            self.render()

    def _is_policy_notice(self, action: Any) -> bool:
        """Whether ``action`` is what :meth:`policy_action` handed out this turn, unmodified.

        Never with ``monitor_action="flags"``: that monitor sends no sizes, while the configured
        policy's notification has them.
        """
        scripted = self._scripted_notice
        if (
            scripted is None
            or action is not scripted[0]
            or scripted[2] is None  # flags mode
            or scripted[1] != self._process.t
            or self._process.turn != MONITOR
        ):
            return False
        _, _, flags, sizes, flag_values, size_values = scripted
        return (
            len(action) == 2
            and action.get("env_change") is flags
            and action.get("delta_change") is sizes
            and flags.tolist() == flag_values
            and sizes.tolist() == size_values
        )

    def _notification_of(self, action: Any) -> tuple[list, list]:
        """Flags and sizes of a monitor action (lengths and sizes are checked by the process)."""
        if self._monitor_flags_only:
            flags = _number_list(action, "monitor action", flags=True)
            if not set(flags) <= {0, 1}:
                raise ValueError(f"monitor action={action!r} must hold only 0 and 1")
            return flags, list(self._process.no_change)
        try:
            flags, sizes = action["env_change"], action["delta_change"]
        except (TypeError, KeyError, IndexError):
            raise ValueError(
                f"monitor action={action!r} must be a dict with keys 'env_change' and "
                "'delta_change'"
            ) from None
        flag_list = _number_list(flags, "monitor action env_change", flags=True)
        size_list = _number_list(sizes, "monitor action delta_change")
        if not set(flag_list) <= {0, 1}:
            raise ValueError(f"monitor action env_change={flags!r} must hold only 0 and 1")
        return flag_list, size_list

    # -- scripted agents, ground truth ------------------------------------------------------
    def policy_action(self, agent: str) -> Any:
        """The action the configured policy of ``agent`` takes now (nature or monitor).

        The policy is asked once per turn: calling this again in the same turn returns the same
        action, and the schedule advances once per step. For nature it returns the action in the
        game's convention; a scripted value may lie beyond it (a jump larger than the
        allowance) or miss by a rounding error (no float Δ turns 1.0 into 0.3 exactly), so the
        game remembers the exact values behind the array it hands out and grants those when
        that same, unmodified array is stepped in this turn. Likewise the monitor's exact
        notification (float64 sizes) is sent when its unmodified action is stepped.

        Raises:
            ValueError: ``agent`` is not ``"nature"`` or ``"monitor"``, or it is not its turn.
            ResetNeeded: No episode is running.
        """
        process = self._process
        _check_agent(agent)
        if agent == NATURE:
            proposal = process.scripted_proposal()
            scripted = self._scripted
            if scripted is not None and scripted[3] == process.t:
                return scripted[0]
            delta = self._nature.action_of(process.theta, proposal)
            self._scripted = (delta, delta.tolist(), proposal, process.t)
            return delta
        if agent == MONITOR:
            flags, sizes = process.scripted_notification()
            handed_out = self._scripted_notice
            if handed_out is not None and handed_out[1] == process.t:
                return handed_out[0]
            if self._monitor_flags_only:
                notice = np.array(flags, np.int64)
                self._scripted_notice = (notice, process.t, None, None, [], [])
                return notice
            flag_array, size_array = process.build.notification(flags, sizes, process.no_change)
            # Stepped unmodified, the exact notification behind it is played (as for nature).
            self._scripted_notice = (
                {"env_change": flag_array, "delta_change": size_array},
                process.t,
                flag_array,
                size_array,
                flag_array.tolist(),
                size_array.tolist(),
            )
            return self._scripted_notice[0]
        raise ValueError(
            f"agent={agent!r} has no configured policy; allowed: {NATURE!r}, {MONITOR!r}"
        )

    def ground_truth(self) -> GroundTruth:
        """The true θ_0, current θ and change times of this episode (for evaluation)."""
        return self._process.ground_truth()

    def planning_model(self) -> Any:
        """A stationary planning model for the decision agent under the planning θ.

        θ_0, or at ``detailed`` the latest θ the agent has been told of (with the exact oracle
        θ_{t-1}; see :meth:`~ns_pz.process.NSProcess.planning_theta`).
        """
        return self._process.planning_model()

    @property
    def nature_action(self) -> str:
        """Nature's action convention: ``"delta"`` or ``"normalized"``."""
        return self._nature.action_mode

    @property
    def nature_action_space(self) -> spaces.Box:
        """Nature's action space, typed as the ``Box`` it is."""
        return self._nature.action_space

    @property
    def family(self) -> EnvFamily:
        """The environment family."""
        return self._process.family

    @property
    def process(self) -> NSProcess:
        """The process this game drives (for adapters and exact tools)."""
        return self._process

    def render(self) -> None | np.ndarray | str:
        """The environment's state under the θ in force, in :attr:`render_mode`.

        A ``uint8`` frame ``[height, width, 3]`` (``"rgb_array"``), text (``"ansi"``), or
        ``None`` (``"human"``, which draws into a window, or no render mode).

        Raises:
            ResetNeeded: Called before the first reset.
        """
        return self._renderer.render(self._process)

    def close(self) -> None:
        """Close the render window, if one is open."""
        self._renderer.close()


def _check_agent(agent: str) -> str:
    if agent not in AGENTS:
        raise ValueError(f"agent={agent!r} is not one of {AGENTS}")
    return agent


def _number_list(value: Any, what: str, *, flags: bool = False) -> list:
    """A 1-D real array or sequence as a list of Python numbers (bools only for ``flags``)."""
    kinds = "fiub" if flags else "fiu"
    if type(value) is np.ndarray and value.ndim == 1 and value.dtype.kind in kinds:
        return value.tolist()
    scalars: tuple[type, ...] = (int, float, bool) if flags else (int, float)
    if isinstance(value, (list, tuple)) and all(
        type(x) in scalars or isinstance(x, (np.floating, np.integer)) for x in value
    ):
        return [float(x) for x in value]
    raise ValueError(f"{what}={value!r} is not a real numeric vector")
