"""Any seat of the game as a single-agent Gymnasium environment: who learns, and against whom.

:func:`single_agent` turns the NS-MDP game into an ordinary ``gymnasium.Env`` seen from one
seat — ``"agent"`` (the decision maker; this is the usual Gymnasium view), ``"nature"`` (an
adversary, a cooperative shaper, a regret maximiser) or ``"monitor"`` (a learned detector) —
with the two other seats played by fixed policies. Every seat is driven through the same
:class:`~ns_pz.process.NSProcess` cycle as the game and the view, so a policy trained here acts
identically when put back into them (:class:`~ns_pz.nature.PolicyNature`,
:class:`~ns_pz.monitor.PolicyMonitor`).

One step of a learner environment is one turn of its seat followed by the other seats' turns
until the learner's next turn (or the end of the episode); its reward is what the game pays that
seat over those turns. One seed at ``reset`` seeds the environment, nature, the monitor, the
planning models and the policies playing the other seats.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym
from gymnasium import spaces

from ns_pz.checks import flag
from ns_pz.monitor.features import MonitorFeatures
from ns_pz.monitor.learned import PolicyMonitor
from ns_pz.monitor.monitors import Monitor, as_flags
from ns_pz.monitor.scoring import (  # DetectionReward: still importable from here, its old home
    DetectionReward,  # noqa: F401
    MonitorRewardFn,
    monitor_reward_of,
    monitor_reward_value,
)
from ns_pz.nature.interface import DEFAULT_STEP, NATURE_ACTIONS, check_default_step
from ns_pz.nature.learned import PolicyNature
from ns_pz.nature.policies import Nature
from ns_pz.observations import monitor_flags_space, monitor_observation_space
from ns_pz.process import AGENTS, DECISION, MONITOR, NATURE, NSProcess
from ns_pz.regret import NATURE_REWARDS, NatureReward, RegretReference, default_reference
from ns_pz.rendering import Renderer, render_metadata
from ns_pz.seat_policies import DecisionPolicy, check_policy
from ns_pz.views import ProcessEnv, reset_seeded


def single_agent(
    env: str,
    learner: str = "agent",
    policies: Mapping[str, Any] | None = None,
    *,
    nature_reward: str = "zero_sum",
    regret_reference: RegretReference | None = None,
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    monitor_reward: MonitorRewardFn | str | None = None,
    monitor_features: MonitorFeatures | None = None,
    deterministic: bool = True,
    **env_kwargs: Any,
) -> gym.Env:
    """The game of a registered environment seen from ``learner``'s seat.

    Args:
        env: A registered id (``"ns_pz/CartPole-v0"``).
        learner: ``"agent"``, ``"nature"`` or ``"monitor"``.
        policies: Who plays the other seats, by seat name: a callable ``obs -> action``, an
            SB3-style model (``predict``), an ns_pz ``Agent`` for the agent's seat, or a
            :class:`~ns_pz.nature.Nature` / :class:`~ns_pz.monitor.Monitor` object. Left out:
            the ``nature=`` / ``monitor=`` of ``env_kwargs`` (a schedule, the oracle). The
            agent's seat must be given when it is not the learner.
        nature_reward: Nature's payoff when it learns: ``"zero_sum"``, ``"cooperative"``,
            ``"none"`` or ``"regret"`` (see :mod:`ns_pz.regret`).
        regret_reference: The reference of ``"regret"``; default: the exact oracle on a
            tabular family (:class:`ns_pz.agents.exact.OracleReference`).
        nature_action: Nature's action convention (learner or policy): ``"normalized"``
            (``Box(-1, 1)`` per allowance) or ``"delta"`` (see :mod:`ns_pz.nature.interface`).
        nature_observes_state: Nature sees the agent's state and last action.
        default_step: Per-step allowance of a parameter without a Lipschitz bound, as a
            fraction of its size at θ_0 (see :mod:`ns_pz.nature.interface`).
        monitor_reward: What the learning monitor earns per turn: ``"detection"`` (a
            :class:`~ns_pz.monitor.DetectionReward` with λ = 10) or any
            ``fn(process, flags) -> float``; an object with a ``reset()`` method (a
            :class:`~ns_pz.monitor.DetectionReward` of your own λ) is copied, so one instance
            may serve several environments. Required for
            ``learner="monitor"``. The episode's last transition, which no monitor turn
            follows, is paid as if the monitor stayed silent about it (with the last step's
            reward): a change still undetected then is charged.
        monitor_features: A :class:`~ns_pz.monitor.MonitorFeatures` giving the learning
            monitor memory (a normalised clock, evidence since its last alarm); put the trained
            policy back with ``PolicyMonitor(model, features=<the same>)``.
        deterministic: Ask SB3-style policies of the other seats deterministically; when
            sampling, they draw from the seed (see :func:`ns_pz.seat_policies.call_policy`).
        **env_kwargs: The environment's arguments (``params``, ``nature``, ``monitor``,
            ``notification``, ``constraints``, ``max_episode_steps``, ``render_mode``,
            ``ground_truth_info``, family arguments).

    The options of one seat apply only where that seat is played as they describe:
    ``nature_reward`` and ``regret_reference`` when nature learns, ``monitor_reward`` when the
    monitor learns, ``nature_action``, ``nature_observes_state`` and ``default_step`` when
    nature learns or ``policies["nature"]`` is a bare policy (a :class:`PolicyNature` carries its
    own, which they must then match). Elsewhere they would be silently ignored, so a value other
    than the default is refused, as is a seat given twice (in ``policies`` and as ``nature=`` /
    ``monitor=``) or a schedule for the seat that learns.

    Raises:
        ValueError / TypeError: An unknown learner or seat, a missing or unusable policy, an
            option outside its allowed values or for a seat it does not apply to.
    """
    from ns_pz.envs.registry import make_gym

    if learner not in AGENTS:
        raise ValueError(f"learner={learner!r}; allowed: {AGENTS}")
    policies = dict(policies or {})
    for seat in policies:
        if seat not in AGENTS:
            raise ValueError(f"policies has a seat {seat!r}; allowed: {AGENTS}")
    if learner in policies:
        raise ValueError(f"policies[{learner!r}] is given, but {learner!r} is the learner")
    options: dict[str, Any] = {
        "nature_reward": nature_reward,
        "regret_reference": regret_reference,
        "nature_action": nature_action,
        "nature_observes_state": nature_observes_state,
        "default_step": default_step,
        "monitor_reward": monitor_reward,
        "monitor_features": monitor_features,
    }
    _check_seat_options(learner, policies, env_kwargs, **options)
    flag("deterministic", deterministic)
    if NATURE in policies:
        env_kwargs["nature"] = _as_nature(
            policies[NATURE], nature_action, nature_observes_state, default_step, deterministic
        )
    if MONITOR in policies:
        env_kwargs["monitor"] = _as_monitor(policies[MONITOR], deterministic)
    if DECISION in policies:
        check_policy(policies[DECISION], DECISION)
    elif learner != DECISION:
        raise ValueError(
            f"policies[{DECISION!r}] is needed: who plays the decision agent while {learner!r} "
            "learns (a callable, an SB3 model or an ns_pz Agent)"
        )
    if learner == DECISION:
        return make_gym(env, **env_kwargs)
    options.update({k: env_kwargs.pop(k) for k in _SEAT_ENV_KWARGS if k in env_kwargs})
    view = make_gym(env, **env_kwargs)
    decide = DecisionPolicy(policies[DECISION], deterministic=deterministic)
    return SeatEnv(view.process, learner, decide, **options)


_SEAT_ENV_KWARGS = ("render_mode", "ground_truth_info")
"""Arguments of the view that a learner seat's environment takes itself."""


def _check_seat_options(
    learner: str,
    policies: Mapping[str, Any],
    env_kwargs: Mapping[str, Any],
    *,
    nature_reward: str,
    regret_reference: RegretReference | None,
    nature_action: str,
    nature_observes_state: bool,
    default_step: float,
    monitor_reward: MonitorRewardFn | str | None,
    monitor_features: MonitorFeatures | None,
) -> None:
    """Refuse options outside their values, and options for a seat they would not reach."""
    if monitor_features is not None and not isinstance(monitor_features, MonitorFeatures):
        raise TypeError(f"monitor_features={monitor_features!r} must be None or MonitorFeatures")
    if nature_reward not in NATURE_REWARDS:
        raise ValueError(f"nature_reward={nature_reward!r}; allowed: {NATURE_REWARDS}")
    if nature_action not in NATURE_ACTIONS:
        raise ValueError(f"nature_action={nature_action!r}; allowed: {NATURE_ACTIONS}")
    flag("nature_observes_state", nature_observes_state)
    check_default_step(default_step)
    monitor_reward_of(monitor_reward)  # refuses anything else than None, "detection", a function
    for seat in (NATURE, MONITOR):
        if seat not in env_kwargs:
            continue
        if seat == learner:
            raise ValueError(
                f"{seat}={env_kwargs[seat]!r} is given, but {seat!r} is the learner: its "
                "policy is the one being trained"
            )
        if seat in policies:
            raise ValueError(
                f"policies[{seat!r}] and {seat}= both say who plays {seat!r}; give one"
            )
    if learner != NATURE:
        if nature_reward != "zero_sum" or regret_reference is not None:
            raise ValueError(
                f"nature_reward={nature_reward!r} / regret_reference={regret_reference!r} "
                f"apply only when nature learns, not with learner={learner!r}"
            )
        nature = policies[NATURE] if NATURE in policies else env_kwargs.get(NATURE)
        _check_nature_conventions(nature, nature_action, nature_observes_state, default_step)
    for name, value in (("monitor_reward", monitor_reward), ("monitor_features", monitor_features)):
        if learner != MONITOR and value is not None:
            raise ValueError(
                f"{name}={value!r} applies only when the monitor learns, not with "
                f"learner={learner!r}"
            )


def _check_nature_conventions(
    policy: Any, action: str, observes_state: bool, default_step: float
) -> None:
    """Nature's conventions when nature does not learn: for a bare policy, or matching its own."""
    given = {
        "nature_action": action,
        "nature_observes_state": observes_state,
        "default_step": default_step,
    }
    if policy is not None and not isinstance(policy, Nature):
        return  # a bare policy: wrapped in a PolicyNature with these conventions
    if isinstance(policy, PolicyNature):
        own = {
            "nature_action": policy.action,
            "nature_observes_state": policy.observes_state,
            "default_step": policy.default_step,
        }
        clashes = [
            f"{k}={v!r} (its own: {own[k]!r})"
            for k, v in given.items()
            if v != _DEFAULT_CONVENTIONS[k] and v != own[k]  # set here, and not as its own
        ]
        if clashes:
            raise ValueError(
                f"policies['nature'] is {policy!r}, which carries its own conventions; "
                f"{', '.join(clashes)}: build the PolicyNature with them instead"
            )
        return
    moved = [f"{k}={v!r}" for k, v in given.items() if v != _DEFAULT_CONVENTIONS[k]]
    if moved:
        raise ValueError(
            f"{', '.join(moved)} apply only to a learning nature or a bare policy in "
            "policies['nature']; here nature is a schedule or a Nature object"
        )


_DEFAULT_CONVENTIONS = {
    "nature_action": "normalized",
    "nature_observes_state": False,
    "default_step": DEFAULT_STEP,
}


class SeatEnv(ProcessEnv, gym.Env[Any, Any]):
    """A Gymnasium environment in which nature or the monitor learns (see :func:`single_agent`).

    Args:
        process: The process to drive (its nature and monitor play the other seats).
        learner: ``"nature"`` or ``"monitor"``.
        decide: Plays the decision agent's turns.
        nature_reward / regret_reference / nature_action / nature_observes_state /
        default_step / monitor_reward / monitor_features: As in :func:`single_agent`.
        render_mode: ``None`` or one of the family's modes, as for the view (a ``"human"``
            window is redrawn after every step of this environment).
        ground_truth_info: Put the θ of the last transition into ``info["theta"]``.
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        process: NSProcess,
        learner: str,
        decide: DecisionPolicy,
        *,
        nature_reward: str = "zero_sum",
        regret_reference: RegretReference | None = None,
        nature_action: str = "normalized",
        nature_observes_state: bool = False,
        default_step: float = DEFAULT_STEP,
        monitor_reward: MonitorRewardFn | str | None = None,
        monitor_features: MonitorFeatures | None = None,
        render_mode: str | None = None,
        ground_truth_info: bool = False,
    ) -> None:
        if learner not in (NATURE, MONITOR):
            raise ValueError(f"learner={learner!r}; a SeatEnv serves {NATURE!r} or {MONITOR!r}")
        self._process = process
        self.learner = learner
        self._decide = decide
        self._renderer = Renderer(process.family, render_mode)
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, **render_metadata(process.family)}
        self._ground_truth_info = flag("ground_truth_info", ground_truth_info)
        if learner == NATURE:
            if nature_reward == "regret" and regret_reference is None:
                regret_reference = default_reference(process.family)
            self._nature_reward = NatureReward(nature_reward, regret_reference)
            self._interface = process.nature_interface(
                nature_action, nature_observes_state, default_step
            )
            self.observation_space = self._interface.observation_space
            self.action_space: spaces.Space[Any] = self._interface.action_space
        else:
            reward_fn = monitor_reward_of(monitor_reward)
            if reward_fn is None:
                raise ValueError(
                    f"monitor_reward={monitor_reward!r}: a learning monitor needs a reward: "
                    "'detection' or a function fn(process, flags) -> float"
                )
            self._monitor_reward = reward_fn
            self._features = monitor_features
            self._feature_memory: Any = None
            if monitor_features is not None:
                monitor_features.bind(process.family, process.base_theta0)
            self.observation_space = monitor_observation_space(process.family, monitor_features)
            self.action_space = monitor_flags_space(process.family.params_cls)

    @property
    def process(self) -> NSProcess:
        """The process this environment drives."""
        return self._process

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Start an episode and play the other seats up to the learner's first turn.

        Args:
            seed: Seeds the environment, nature, the monitor and the other seats' policies.
            options: ``{"params": θ_0}`` starts this episode from another θ_0.
        """
        process = reset_seeded(self, self._process, seed, options)
        self._decide.reset(process.seat_rng())
        if self.learner == MONITOR:
            reset = getattr(self._monitor_reward, "reset", None)
            if callable(reset):
                reset()
            if self._features is not None:
                self._feature_memory = self._features.episode_memory(process.nominal_theta0)
        process.play_until(self.learner, self._decide)
        if self.render_mode == "human":
            self.render()
        return self._observe(), self._info()

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """The learner's turn, then the other seats' turns until its next one.

        Raises:
            ResetNeeded: No episode is running.
            ValueError: ``action`` is outside the action space.
        """
        process = self._process
        if process.done:
            process.check_running("step()")
        if self.learner == NATURE:
            process.nature_turn(self._interface.proposal(action, process.theta))
            agent_total, _ = process.play_until(NATURE, self._decide)
            reward = self._nature_reward.per_step(agent_total)
            if process.done:
                reward += self._nature_reward.at_end(process)
        else:
            flags = _flags_of(action, len(process.no_change))
            process.monitor_turn(flags, process.no_change)
            reward = monitor_reward_value(self._monitor_reward, process, flags)
            if self._features is not None:
                self._features.alarmed(self._feature_memory, flags)
            process.play_until(MONITOR, self._decide)
            if process.done:  # no monitor turn follows the last transition: silence about it
                reward += float(self._monitor_reward(process, process.no_change))
        terminated, truncated = process.ended if process.done else (False, False)
        if self.render_mode == "human":
            self.render()
        return self._observe(), float(reward), terminated, truncated, self._info()

    def _observe(self) -> Any:
        process = self._process
        if self.learner == NATURE:
            return self._interface.observe(process)
        observation = process.build.monitor(process)
        if self._features is None:
            return observation
        self._features.update(self._feature_memory, observation)
        return self._features.observation(observation, self._feature_memory)

    def ground_truth(self) -> Any:
        """The true θ trajectory of this episode (for evaluation)."""
        return self._process.ground_truth()

    def __repr__(self) -> str:
        return f"SeatEnv(learner={self.learner!r}, {self._process.family!r})"


def _as_nature(
    policy: Any, action: str, observes_state: bool, default_step: float, deterministic: bool
) -> Nature:
    if isinstance(policy, Nature):
        return policy
    return PolicyNature(
        policy,
        action=action,
        observes_state=observes_state,
        default_step=default_step,
        deterministic=deterministic,
    )


def _as_monitor(policy: Any, deterministic: bool) -> Monitor:
    if isinstance(policy, Monitor):
        return policy
    return PolicyMonitor(policy, deterministic=deterministic)


def _flags_of(action: Any, count: int) -> tuple[int, ...]:
    flags = as_flags(action, count, kinds="iub")
    if flags is None:
        raise ValueError(f"monitor action={action!r} must be {count} flags of 0/1")
    return flags
