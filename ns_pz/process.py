"""The transition core shared by the AEC game and the Gymnasium view.

One :class:`NSProcess` runs one NS-MDP episode at a time. A time step ``t`` has three turns:

1. :meth:`NSProcess.nature_turn` grants nature's proposal (projected onto the allowed set): θ_t;
2. :meth:`NSProcess.notification` is what the monitor tells the agent, about the change behind
   the last transition (θ_{t-1} against θ_{t-2}): never about θ_t, which no one has seen act yet;
3. :meth:`NSProcess.transition` draws ``s_{t+1}`` under θ_t and advances ``t``.

The game calls these from its three agents' turns; the view calls them in a row inside one
``step``. Both therefore produce identical trajectories for the same seed and actions.

Randomness: :meth:`NSProcess.seed` turns one seed into independent generators through
``numpy.random.SeedSequence``: the environment's (``Generator(PCG64(SeedSequence(seed)))``, which
is what Gymnasium's ``np_random`` would be), nature's, the monitor's, and a seed sequence from
which each planning model gets a fresh child. No global generator is used anywhere.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ns_pz.errors import ResetNeeded
from ns_pz.family import EnvFamily, State
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints, admit
from ns_pz.nature.policies import Nature, StaticNature
from ns_pz.params import Params


@dataclass(frozen=True)
class GroundTruth:
    """The true non-stationarity of the current episode, for evaluation (never shown to agents).

    Attributes:
        theta0: θ at reset.
        theta: θ in force now (the one the last transition used).
        change_times: Steps at which θ changed (a change at ``t`` applies to transition ``t``).
        change_values: θ after each of those changes.
        budget_used: Sum of all change sizes so far.
    """

    theta0: Params
    theta: Params
    change_times: tuple[int, ...]
    change_values: tuple[Params, ...]
    budget_used: float


class NSProcess:
    """One NS-MDP: a family, θ_0, nature, monitor, notification level, constraints, time limit.

    Args:
        family: The environment family.
        params: θ_0, as a parameter set or a mapping of names to values (others default).
        nature: Who changes θ (default: nobody, a stationary env).
        monitor: Who decides the notification (default: the oracle).
        notification: ``"none"``, ``"basic"`` or ``"detailed"``.
        constraints: Lipschitz bound and budget on nature.
        max_episode_steps: Transitions after which the episode is truncated; ``None``: never
            (the Gymnasium registration leaves truncation to Gymnasium's ``TimeLimit``).

    Raises:
        TypeError / ValueError: Any argument of the wrong type or value, before anything runs.
    """

    def __init__(
        self,
        family: EnvFamily,
        *,
        params: Params | Mapping[str, Any] | None = None,
        nature: Nature | None = None,
        monitor: Monitor | None = None,
        notification: str | NotificationLevel = "none",
        constraints: NatureConstraints | None = None,
        max_episode_steps: int | None,
    ) -> None:
        if not isinstance(family, EnvFamily):
            raise TypeError(f"family={family!r} must be an ns_pz EnvFamily")
        self.family = family
        self.theta0 = _check_params(family, params)
        self.nature = StaticNature() if nature is None else nature
        if not isinstance(self.nature, Nature):
            raise TypeError(
                f"nature={nature!r} must be an ns_pz Nature (ScriptedNature, RandomNature, ...)"
            )
        self.nature.bind(family.params_cls)
        self.monitor = OracleMonitor() if monitor is None else monitor
        if not isinstance(self.monitor, Monitor):
            raise TypeError(f"monitor={monitor!r} must be an ns_pz Monitor (e.g. OracleMonitor())")
        self.level = NotificationLevel.parse(notification)
        self.constraints = NatureConstraints() if constraints is None else constraints
        if not isinstance(self.constraints, NatureConstraints):
            raise TypeError(f"constraints={constraints!r} must be a NatureConstraints")
        self.constraints.check_names(family.params_cls)
        if max_episode_steps is not None:
            if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, int):
                raise TypeError(f"max_episode_steps={max_episode_steps!r} must be an int or None")
            if max_episode_steps < 1:
                raise ValueError(f"max_episode_steps={max_episode_steps!r} must be >= 1")
        self.max_episode_steps = max_episode_steps

        self.param_names = family.params_cls.names()
        self.no_change: tuple[float, ...] = (0.0,) * len(self.param_names)
        self.env_rng: np.random.Generator | None = None
        self.nature_rng: np.random.Generator | None = None
        self.monitor_rng: np.random.Generator | None = None
        self._planning_seeds: np.random.SeedSequence | None = None
        self.started = False
        self.done = True
        self.state: State = None
        self.theta = self.theta0
        self._step_start_theta = self.theta0
        self.t = 0
        self.last_action: Any = None
        self.last_reward = 0.0
        self.last_state: State = None
        self.pending_sizes = self.no_change
        self.last_sizes = self.no_change
        self.budget_used = 0.0
        self.change_times: list[int] = []
        self.change_values: list[Params] = []
        self.nature_memory: Any = None
        self.monitor_memory: Any = None

    # -- seeding and reset ------------------------------------------------------------------
    def seed(self, seed: int | np.random.SeedSequence | None) -> None:
        """Derive every generator from one seed (``None``: fresh OS entropy)."""
        root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        self.env_rng = np.random.Generator(np.random.PCG64(root))
        nature_seq, monitor_seq, planning_seq = root.spawn(3)
        self.nature_rng = np.random.Generator(np.random.PCG64(nature_seq))
        self.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        self._planning_seeds = planning_seq

    def reset(self) -> None:
        """Start an episode: θ back to θ_0, a start state drawn, the clock at 0."""
        if self.env_rng is None:
            self.seed(None)
        self.state = self.family.initial_state(self.env_rng)
        self.theta = self.theta0
        self._step_start_theta = self.theta0
        self.t = 0
        self.last_action = None
        self.last_reward = 0.0
        self.last_state = self.state
        self.pending_sizes = self.no_change
        self.last_sizes = self.no_change
        self.budget_used = 0.0
        self.change_times = []
        self.change_values = []
        self.nature_memory = self.nature.initial_memory()
        self.monitor_memory = self.monitor.initial_memory()
        self.started = True
        self.done = False

    def check_running(self, what: str) -> None:
        """Raise :class:`ResetNeeded` unless an episode is running."""
        if not self.started:
            raise ResetNeeded(f"{what} called before reset(); call reset() first")
        if self.done:
            raise ResetNeeded(f"{what} called after the episode ended; call reset() first")

    # -- the three turns --------------------------------------------------------------------
    @property
    def budget_left(self) -> float:
        """What remains of nature's budget this episode (``inf`` when unlimited)."""
        budget = self.constraints.budget
        return math.inf if budget is None else max(budget - self.budget_used, 0.0)

    def scripted_proposal(self) -> Mapping[str, Any] | None:
        """What the configured nature policy proposes at this step (advances its memory)."""
        return self.nature.propose(
            self.t, self.theta, self.budget_left, self.nature_memory, self.nature_rng  # type: ignore[arg-type]
        )

    def nature_turn(self, proposal: Mapping[str, Any] | None) -> None:
        """Grant nature's proposal for step ``t``, projected onto the allowed set."""
        if not proposal:
            return
        theta, sizes = admit(self.theta, proposal, self.constraints, self.budget_left)
        if theta is self.theta:
            return
        self.budget_used += math.fsum(sizes.values())
        self._record_change(theta, sizes)

    def set_params(self, changes: Mapping[str, Any]) -> None:
        """Change θ now, by hand: validated strictly (no projection), applies to transition ``t``.

        Recorded in the ground truth and notified like a change by nature; not charged to
        nature's budget.

        Raises:
            UnknownParam: A name is not a parameter.
            ParamOutOfRange: A value is invalid.
        """
        theta = self.theta.replace(**changes)
        sizes = theta.change_sizes(self.theta)
        if any(sizes):
            self._record_change(theta, dict(zip(self.param_names, sizes, strict=True)))

    def _record_change(self, theta: Params, sizes: Mapping[str, float]) -> None:
        if self.pending_sizes is self.no_change:
            self.pending_sizes = tuple(sizes.get(name, 0.0) for name in self.param_names)
        else:  # a second change within one step: measure against θ at the start of the step
            self.pending_sizes = theta.change_sizes(self._step_start_theta)
        self.theta = theta
        if self.change_times and self.change_times[-1] == self.t:
            self.change_values[-1] = theta
        else:
            self.change_times.append(self.t)
            self.change_values.append(theta)

    def notification(self, observation: dict[str, Any] | None = None) -> tuple[tuple, tuple]:
        """The monitor's message about the last transition, masked to the level.

        Returns:
            ``(flags, sizes)``, one entry per parameter in field order; zeros where the level
            hides them.
        """
        level = self.level
        if level is NotificationLevel.NONE or (
            self.monitor.reads_ground_truth and self.last_sizes is self.no_change
        ):
            return self.no_change, self.no_change
        truth = self.last_sizes if self.monitor.reads_ground_truth else None
        flags, sizes = self.monitor.notify(observation, truth, self.monitor_memory, self.monitor_rng)  # type: ignore[arg-type]
        return mask_notification(level, flags, sizes, len(self.param_names))

    def transition(self, action: Any) -> tuple[float, bool, bool]:
        """Draw the next state under the current θ and advance the clock.

        Returns:
            ``(reward, terminated, truncated)``.
        """
        self.last_state = self.state
        self.state, reward, terminated = self.family.step(
            self.state, action, self.theta, self.env_rng  # type: ignore[arg-type]
        )
        self.last_action = action
        self.last_reward = reward
        self.last_sizes = self.pending_sizes
        self.pending_sizes = self.no_change
        self._step_start_theta = self.theta
        self.t += 1
        limit = self.max_episode_steps
        truncated = limit is not None and self.t >= limit
        self.done = terminated or truncated
        return reward, terminated, truncated

    # -- what agents may be handed ----------------------------------------------------------
    def planning_theta(self) -> Params:
        """θ the agent's planning model assumes: the current θ at ``detailed``, else θ_0."""
        return self.theta if self.level.shows_sizes else self.theta0

    def planning_rng(self) -> np.random.Generator:
        """A fresh generator for one planning model, from the seed (deterministic sequence)."""
        if self._planning_seeds is None:
            self.seed(None)
        child = self._planning_seeds.spawn(1)[0]  # type: ignore[union-attr]
        return np.random.Generator(np.random.PCG64(child))

    def planning_model(self) -> Any:
        """A stationary model at the current state under :meth:`planning_theta`."""
        if not self.started:
            raise ResetNeeded("planning_model() called before reset(); call reset() first")
        return self.family.planning_model(self.planning_theta(), self.state, self.planning_rng())

    def stationary_copy(self) -> NSProcess:
        """A process at the current state and time whose θ is frozen at :meth:`planning_theta`.

        Nature is static in the copy; it shares the family, monitor and level, and draws from a
        fresh planning generator. Its own ``reset`` starts new episodes under the frozen θ.
        """
        if not self.started:
            raise ResetNeeded("get_planning_env() called before reset(); call reset() first")
        twin = copy.copy(self)
        theta = self.planning_theta()
        twin.theta0 = twin.theta = twin._step_start_theta = theta
        twin.nature = _STATIC
        twin.nature_memory = None
        twin.constraints = _UNCONSTRAINED
        twin.env_rng = self.planning_rng()
        twin.pending_sizes = twin.last_sizes = self.no_change
        twin.change_times = []
        twin.change_values = []
        twin.budget_used = 0.0
        return twin

    def ground_truth(self) -> GroundTruth:
        """The true θ trajectory of this episode so far."""
        return GroundTruth(
            self.theta0,
            self.theta,
            tuple(self.change_times),
            tuple(self.change_values),
            self.budget_used,
        )


_STATIC = StaticNature()
_UNCONSTRAINED = NatureConstraints()


def mask_notification(
    level: NotificationLevel, flags: Any, sizes: Any, count: int
) -> tuple[tuple[int, ...], tuple[float, ...]]:
    """Keep what the level shows of a notification; validate its shape.

    Raises:
        ValueError: ``flags`` or ``sizes`` do not have one entry per parameter, or a size is
            negative or not finite.
    """
    flags = tuple(int(bool(f)) for f in flags)
    sizes = tuple(float(s) for s in sizes)
    if len(flags) != count or len(sizes) != count:
        raise ValueError(
            f"a notification needs {count} flags and {count} sizes (one per parameter), "
            f"got {len(flags)} and {len(sizes)}"
        )
    if not all(math.isfinite(s) and s >= 0.0 for s in sizes):
        raise ValueError(f"notification sizes {sizes!r} must be finite and >= 0")
    if not level.shows_flags:
        return (0,) * count, (0.0,) * count
    if not level.shows_sizes:
        return flags, (0.0,) * count
    return flags, sizes


def _check_params(family: EnvFamily, params: Params | Mapping[str, Any] | None) -> Params:
    cls = family.params_cls
    if params is None:
        return family.default_params()
    if isinstance(params, cls):
        return params
    if isinstance(params, Mapping):
        return cls.from_mapping(params)
    raise TypeError(
        f"params={params!r} must be a {cls.__name__} or a mapping of its parameter names to values"
    )
