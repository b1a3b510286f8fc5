"""The NS-MDP as a PettingZoo AEC game: nature, then the monitor, then the decision agent.

Each time step ``t``:

1. ``nature`` observes ``[t, θ_{t-1} (flat), budget_left]`` and acts with Δθ (zero: no change).
   The game projects θ_{t-1} + Δθ onto the allowed set (bounds, Lipschitz bound, budget): θ_t.
2. ``monitor`` observes the last transition and acts with the notification for the agent
   (``env_change`` flags and ``delta_change`` sizes), masked to the game's level.
3. ``agent`` observes the state with that notification and acts; the base environment makes one
   transition under θ_t, and every agent is rewarded: the agent gets r_t, nature -r_t
   (``nature_reward="zero_sum"``, the default) or r_t (``"cooperative"``), the monitor 0.

The episode ends for all three together when the base environment terminates or the time limit
truncates. :meth:`NSGame.policy_action` gives the action of the configured nature and monitor
policies, so any subset of the agents can be scripted while the others learn.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv

from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import Monitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.policies import Nature
from ns_pz.observations import (
    ObservationBuilder,
    agent_observation_space,
    monitor_action_space,
    monitor_observation_space,
    nature_action_space,
    nature_observation_space,
)
from ns_pz.params import SIMPLEX, Params
from ns_pz.process import GroundTruth, NSProcess, mask_notification
from ns_pz.rendering import Renderer, render_metadata

NATURE = "nature"
MONITOR = "monitor"
DECISION = "agent"
AGENTS = (NATURE, MONITOR, DECISION)
NATURE_REWARDS = ("zero_sum", "cooperative", "none")


class NSGame(AECEnv):
    """The NS-MDP game over one environment family.

    Args:
        family: The environment family.
        params: θ_0 (a parameter set or a mapping of names to values).
        nature: The scripted nature policy :meth:`policy_action` follows (default: static).
        monitor: The monitor policy :meth:`policy_action` follows (default: oracle).
        notification: ``"none"``, ``"basic"`` or ``"detailed"``: what reaches the agent.
        constraints: Lipschitz bound and budget enforced on every nature action.
        max_episode_steps: Time steps after which all agents are truncated.
        nature_reward: ``"zero_sum"`` (-r), ``"cooperative"`` (+r) or ``"none"`` (0).
        render_mode: ``None``, or one of the family's modes (``"human"``, ``"rgb_array"``, and
            ``"ansi"`` for grid worlds): :meth:`render` draws the environment's state under the
            θ in force; ``"human"`` redraws after every reset and transition.

    Raises:
        ValueError: ``render_mode`` is not one of the family's modes.
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
        render_mode: str | None = None,
    ) -> None:
        super().__init__()
        self._process = NSProcess(
            family,
            params=params,
            nature=nature,
            monitor=monitor,
            notification=notification,
            constraints=constraints,
            max_episode_steps=max_episode_steps,
        )
        if nature_reward not in NATURE_REWARDS:
            raise ValueError(f"nature_reward={nature_reward!r}; allowed: {NATURE_REWARDS}")
        self._nature_sign = {"zero_sum": -1.0, "cooperative": 1.0, "none": 0.0}[nature_reward]
        self._build = ObservationBuilder(family)
        self._renderer = Renderer(family, render_mode)
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, **render_metadata(family)}
        params_cls = family.params_cls
        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        self.observation_spaces = {
            NATURE: nature_observation_space(params_cls),
            MONITOR: monitor_observation_space(family),
            DECISION: agent_observation_space(family),
        }
        self._nature_space = nature_action_space(params_cls)
        self.action_spaces: dict[str, spaces.Space[Any]] = {
            NATURE: self._nature_space,
            MONITOR: monitor_action_space(params_cls),
            DECISION: family.action_space,
        }
        low, high = self._nature_space.low, self._nature_space.high
        self._delta_bounds = tuple(zip(low.tolist(), high.tolist(), strict=True))
        self._uniform_bounds = self._delta_bounds[0] if len(set(self._delta_bounds)) == 1 else None
        self._flat_layout = [
            (spec.name, spec.kind == SIMPLEX, start, stop)
            for spec, start, stop in params_cls.flat_layout()
        ]
        self._notification: tuple[tuple, tuple] = (self._process.no_change,) * 2
        self._rewarded = False
        self._scripted: tuple[np.ndarray, list, Any] | None = None
        # Before the first reset: calls meet ResetNeeded, not missing attributes.
        self.agent_selection = NATURE
        self.rewards: dict[str, float] = {}
        self._cumulative_rewards: dict[str, float] = {}
        self.terminations: dict[str, bool] = {}
        self.truncations: dict[str, bool] = {}
        self.infos: dict[str, dict[str, Any]] = {}

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The (always identical) observation space of ``agent``."""
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The (always identical) action space of ``agent``."""
        return self.action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        """Start an episode; a seed reseeds the environment, nature, monitor and planning."""
        process = self._process
        if seed is not None or process.env_rng is None:
            process.seed(seed)
        process.reset()
        self.agents = list(AGENTS)
        self.rewards = dict.fromkeys(AGENTS, 0.0)
        self._cumulative_rewards = dict.fromkeys(AGENTS, 0.0)
        self.terminations = dict.fromkeys(AGENTS, False)
        self.truncations = dict.fromkeys(AGENTS, False)
        self.infos = {agent: {} for agent in AGENTS}
        self.agent_selection = NATURE
        self._notification = (process.no_change, process.no_change)
        self._rewarded = False
        self._scripted = None
        if self.render_mode == "human":
            self.render()

    def observe(self, agent: str) -> Any:
        """What ``agent`` sees now (see :mod:`ns_pz.observations`)."""
        process = self._process
        if not process.started:
            process.check_running("observe()")
        if agent == NATURE:
            return self._build.nature(process.t, process.theta, process.budget_left)
        if agent == MONITOR:
            return self._build.monitor(process)
        if agent == DECISION:
            flags, sizes = self._notification
            quiet = flags is process.no_change and sizes is process.no_change
            return self._build.agent(process.state, process.t, flags, sizes, quiet)
        raise ValueError(f"agent={agent!r} is not one of {AGENTS}")

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
            if scripted is not None and action is scripted[0] and action.tolist() == scripted[1]:
                proposal = scripted[2]  # the policy's own values, exact
            else:
                proposal = self._proposal(action)
            process.nature_turn(proposal)
            self._scripted = None
            following = MONITOR
        elif agent == MONITOR:
            flags, sizes = _notification_of(action)
            self._notification = mask_notification(process.level, flags, sizes, process.no_change)
            following = DECISION
        else:
            action = process.family.check_action(action)
        # Rewards arise only from the transition at the end of the decision turn; the other
        # turns just clear them and restart the acting agent's running total.
        self._cumulative_rewards[agent] = 0.0
        if agent == DECISION:
            self._decision_turn(action)
        else:
            self._zero_rewards()
            self.agent_selection = following

    def _zero_rewards(self) -> None:
        if self._rewarded:
            self.rewards = dict.fromkeys(AGENTS, 0.0)
            self._rewarded = False

    def _decision_turn(self, action: Any) -> None:
        process = self._process
        reward, terminated, truncated = process.transition(action)
        reward = float(reward)
        nature_reward = self._nature_sign * reward
        self.rewards = {NATURE: nature_reward, MONITOR: 0.0, DECISION: reward}
        self._rewarded = True
        totals = self._cumulative_rewards
        totals[NATURE] += nature_reward
        totals[DECISION] += reward
        if terminated or truncated:
            self.terminations = dict.fromkeys(AGENTS, bool(terminated))
            self.truncations = dict.fromkeys(AGENTS, bool(truncated))
            self._notification = (process.no_change, process.no_change)
        self.agent_selection = NATURE
        if self.render_mode == "human":
            self.render()

    def _proposal(self, action: Any) -> dict[str, Any] | None:
        """Turn nature's Δθ into a proposal of new values.

        Raises:
            ValueError: The action is not a finite vector inside nature's action space.
        """
        if type(action) is np.ndarray and action.ndim == 1 and action.dtype.kind in "fiu":
            delta = action.tolist()
        else:
            delta = _number_list(action, "nature action")
            if np.ndim(action) != 1:
                delta = []  # reported as outside the space below
        if len(delta) != len(self._delta_bounds):
            raise ValueError(
                f"nature action={action!r} is outside the action space {self.action_spaces[NATURE]}"
            )
        if not any(delta):
            return None
        total = sum(delta)
        if self._uniform_bounds is not None:  # one min/max test; NaN makes the sum fail
            low, high = self._uniform_bounds
            inside = total == total and low <= min(delta) and max(delta) <= high
        else:
            inside = all(
                lo <= v <= hi for v, (lo, hi) in zip(delta, self._delta_bounds, strict=True)
            )
        if not inside:
            raise ValueError(
                f"nature action={action!r} is outside the action space {self.action_spaces[NATURE]}"
            )
        theta = self._process.theta
        proposal: dict[str, Any] = {}
        for name, is_vector, start, stop in self._flat_layout:
            if is_vector:
                chunk = delta[start:stop]
                if any(chunk):
                    value = getattr(theta, name)
                    proposal[name] = tuple([p + d for p, d in zip(value, chunk, strict=True)])
            elif delta[start]:
                proposal[name] = getattr(theta, name) + delta[start]
        return proposal

    # -- scripted agents, ground truth ------------------------------------------------------
    def policy_action(self, agent: str) -> Any:
        """The action the configured policy of ``agent`` takes now (nature or monitor).

        For nature this advances the scripted policy's episode memory, so call it once per
        nature turn. It returns Δθ; θ + Δθ may miss a scripted value by a rounding error (no
        float Δ turns 1.0 into 0.3 exactly), so the game remembers the exact values behind the
        array it hands out and grants those when that same, unmodified array is stepped.

        Raises:
            ValueError: ``agent`` is the decision agent, which has no configured policy.
        """
        process = self._process
        process.check_running("policy_action()")
        if agent == NATURE:
            proposal = process.scripted_proposal()
            delta = delta_of(process.theta, proposal or {}, self._nature_space)
            self._scripted = (delta, delta.tolist(), proposal)
            return delta
        if agent == MONITOR:
            flags, sizes = process.notification(self.observe(MONITOR))
            return {
                "env_change": np.array(flags, np.int8),
                "delta_change": np.array(sizes, np.float32),
            }
        raise ValueError(
            f"agent={agent!r} has no configured policy; allowed: {NATURE!r}, {MONITOR!r}"
        )

    def ground_truth(self) -> GroundTruth:
        """The true θ_0, current θ and change times of this episode (for evaluation)."""
        return self._process.ground_truth()

    def planning_model(self) -> Any:
        """A stationary planning model for the decision agent (θ_0, or θ_t at ``detailed``)."""
        return self._process.planning_model()

    @property
    def nature_action_space(self) -> spaces.Box:
        """Nature's action space, typed as the ``Box`` of Δθ it is."""
        return self._nature_space

    @property
    def family(self) -> EnvFamily:
        """The environment family."""
        return self._process.family

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


def delta_of(theta: Params, proposal: Mapping[str, Any], space: spaces.Box) -> np.ndarray:
    """Δθ (flat, clipped to nature's action space) that moves ``theta`` to the proposed values."""
    current = theta.flat()
    target = current.copy()
    for spec, start, stop in theta.flat_layout():
        if spec.name in proposal:
            target[start:stop] = proposal[spec.name]
    return np.clip(target - current, space.low, space.high)


def _notification_of(action: Any) -> tuple[list, list]:
    """Flags and sizes of a monitor action; lengths and sizes are checked by the masking."""
    try:
        flags, sizes = action["env_change"], action["delta_change"]
    except (TypeError, KeyError, IndexError):
        raise ValueError(
            f"monitor action={action!r} must be a dict with keys 'env_change' and 'delta_change'"
        ) from None
    flag_list = _number_list(flags, "monitor action env_change")
    size_list = _number_list(sizes, "monitor action delta_change")
    if not set(flag_list) <= {0, 1}:
        raise ValueError(f"monitor action env_change={flags!r} must hold only 0 and 1")
    return flag_list, size_list


def _number_list(value: Any, what: str) -> list:
    """A 1-D numeric array or sequence as a list of Python numbers."""
    if type(value) is np.ndarray and value.ndim == 1 and value.dtype.kind in "fiub":
        return value.tolist()
    try:
        return [float(x) for x in np.ravel(value)]
    except (TypeError, ValueError):
        raise ValueError(f"{what}={value!r} is not a numeric vector") from None
