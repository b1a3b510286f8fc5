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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, cast

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
        theta: θ in force now: after nature's latest move, so in the game, between nature's
            turn and the transition, it is θ_t, which no transition has used yet.
        change_times: Steps at which θ changed (a change at ``t`` applies to transition ``t``).
        change_values: θ after each of those changes.
        total_change: Sum of the sizes of all recorded changes, ``set_params`` ones included
            (nature's budget is charged for nature's own moves only).
    """

    theta0: Params
    theta: Params
    change_times: tuple[int, ...]
    change_values: tuple[Params, ...]
    total_change: float


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
        self.monitor.bind(family, self.theta0)
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
        self.last_theta = self.theta0
        """θ that drove the last transition (θ_0 before the first)."""
        self.t = 0
        self.last_action: Any = None
        self.last_reward = 0.0
        self.last_state: State = None
        self.last_change: tuple[Params, Params] | None = None
        """(θ before, θ after) of the change behind the last transition, if there was one."""
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
        self.state = self.family.initial_state(cast(np.random.Generator, self.env_rng))
        self.theta = self.theta0
        self.last_theta = self.theta0
        self.t = 0
        self.last_action = None
        self.last_reward = 0.0
        self.last_state = self.state
        self.last_change = None
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
            self.t,
            self.theta,
            self.budget_left,
            self.nature_memory,
            self.nature_rng,  # type: ignore[arg-type]
        )

    def nature_turn(self, proposal: Mapping[str, Any] | None) -> None:
        """Grant nature's proposal for step ``t``, projected onto the allowed set."""
        if not proposal:
            return
        theta, sizes = admit(self.theta, proposal, self.constraints, self.budget_left)
        if theta is self.theta:
            return
        if sizes is not None:
            self.budget_used += math.fsum(sizes.values())
        self._record_change(theta)

    def set_params(self, changes: Mapping[str, Any]) -> None:
        """Change θ now, by hand: validated strictly (no projection), applies to transition ``t``.

        Recorded in the ground truth and notified like a change by nature; not charged to
        nature's budget.

        Raises:
            UnknownParam: A name is not a parameter.
            ParamOutOfRange: A value is invalid.
        """
        theta = self.theta.replace(**changes)
        if theta != self.theta:
            self._record_change(theta)

    def _record_change(self, theta: Params) -> None:
        """Make ``theta`` the θ in force; log it as the change at step ``t`` (one per step)."""
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
        if level is NotificationLevel.NONE:
            return self.no_change, self.no_change
        truth = None
        if self.monitor.reads_ground_truth:
            if self.last_change is None:
                return self.no_change, self.no_change
            truth = self.last_sizes()
        flags, sizes = self.monitor.notify(
            observation,
            truth,
            self.monitor_memory,
            self.monitor_rng,  # type: ignore[arg-type]
        )
        return mask_notification(level, flags, sizes, self.no_change)

    def last_sizes(self) -> tuple[float, ...]:
        """True size of each parameter's change behind the last transition (zeros if none)."""
        if self.last_change is None:
            return self.no_change
        before, after = self.last_change
        return after.change_sizes(before)

    def transition(self, action: Any) -> tuple[float, bool, bool]:
        """Draw the next state under the current θ and advance the clock.

        Returns:
            ``(reward, terminated, truncated)``.
        """
        self.last_state = self.state
        self.state, reward, terminated = self.family.step(
            self.state,
            action,
            self.theta,
            self.env_rng,  # type: ignore[arg-type]
        )
        self.last_action = action
        self.last_reward = reward
        theta = self.theta
        if theta is self.last_theta:
            self.last_change = None
        else:
            self.last_change = (self.last_theta, theta)
            self.last_theta = theta
        self.t += 1
        limit = self.max_episode_steps
        truncated = limit is not None and self.t >= limit
        self.done = terminated or truncated
        return reward, terminated, truncated

    # -- what agents may be handed ----------------------------------------------------------
    def planning_theta(self) -> Params:
        """θ the agent's planning model assumes: θ_0, or at ``detailed`` the latest θ it knows.

        That is the θ behind the last transition, never one nature has chosen for a transition
        still to come: in the game the agent plans after nature's turn, and must not see it.
        """
        return self.last_theta if self.level.shows_sizes else self.theta0

    def planning_rng(self) -> np.random.Generator:
        """A fresh generator for one planning model, from the seed (deterministic sequence)."""
        return np.random.Generator(np.random.PCG64(self._spawn_planning_seed()))

    def _spawn_planning_seed(self) -> np.random.SeedSequence:
        if self._planning_seeds is None:
            raise ResetNeeded("planning needs a seeded episode; call reset() first")
        return self._planning_seeds.spawn(1)[0]

    def planning_model(self) -> Any:
        """A stationary model at the current state under :meth:`planning_theta`."""
        if not self.started:
            raise ResetNeeded("planning_model() called before reset(); call reset() first")
        return self.family.planning_model(self.planning_theta(), self.state, self.planning_rng())

    def stationary_copy(self, theta: Params | None = None) -> NSProcess:
        """A process at the current state and time whose θ is frozen.

        Args:
            theta: The frozen θ; default :meth:`planning_theta`.

        Nature is static in the copy; it shares the family, monitor and level, and draws from a
        fresh planning generator. Its own ``reset`` starts new episodes under the frozen θ.
        """
        if not self.started:
            raise ResetNeeded("get_planning_env() called before reset(); call reset() first")
        twin = copy.copy(self)
        theta = self.planning_theta() if theta is None else theta
        twin.theta0 = twin.theta = twin.last_theta = theta
        twin.nature = _STATIC
        twin.nature_memory = None
        twin.constraints = _UNCONSTRAINED
        # Own streams, so using the twin never touches ours; its static nature draws nothing.
        root = self._spawn_planning_seed()
        monitor_seq, planning_seq = root.spawn(2)
        twin.env_rng = np.random.Generator(np.random.PCG64(root))
        twin.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        twin.nature_rng = twin.env_rng
        twin._planning_seeds = planning_seq
        twin.monitor_memory = self.monitor.initial_memory()
        twin.last_change = None
        twin.change_times = []
        twin.change_values = []
        twin.budget_used = 0.0
        return twin

    def continuing_copy(self, theta: Params | None = None) -> NSProcess:
        """A process at the current state and time in which nature keeps acting.

        Args:
            theta: The θ the copy continues from (and starts its own episodes with); default
                :meth:`planning_theta`.

        Nature's episode memory and the budget used are copied, so the schedule carries on
        where it is; the copy draws from fresh generators derived from the planning seed, so
        using it never touches this process's streams, and two copies differ.
        """
        if not self.started:
            raise ResetNeeded("get_planning_env() called before reset(); call reset() first")
        twin = copy.copy(self)
        theta = self.planning_theta() if theta is None else theta
        twin.theta0 = twin.theta = twin.last_theta = theta
        twin.nature_memory = copy.deepcopy(self.nature_memory)
        root = self._spawn_planning_seed()
        nature_seq, monitor_seq, planning_seq = root.spawn(3)
        twin.env_rng = np.random.Generator(np.random.PCG64(root))
        twin.nature_rng = np.random.Generator(np.random.PCG64(nature_seq))
        twin.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        twin._planning_seeds = planning_seq
        twin.monitor_memory = self.monitor.initial_memory()
        twin.last_change = None
        twin.change_times = []
        twin.change_values = []
        return twin

    def ground_truth(self) -> GroundTruth:
        """The true θ trajectory of this episode so far."""
        total = 0.0
        previous = self.theta0
        for value in self.change_values:
            total += math.fsum(value.change_sizes(previous))
            previous = value
        return GroundTruth(
            self.theta0, self.theta, tuple(self.change_times), tuple(self.change_values), total
        )


_STATIC = StaticNature()
_UNCONSTRAINED = NatureConstraints()


def mask_notification(
    level: NotificationLevel, flags: Sequence[Any], sizes: Sequence[Any], no_change: tuple
) -> tuple[tuple, tuple]:
    """Keep what the level shows of a notification, after checking it.

    Args:
        level: The notification level.
        flags: One 0/1 flag per parameter.
        sizes: One change size per parameter.
        no_change: The process's all-zero tuple, returned for what the level hides.

    Raises:
        ValueError: ``flags`` or ``sizes`` do not have one entry per parameter, or a size is
            negative or not finite.
    """
    count = len(no_change)
    if len(flags) != count or len(sizes) != count:
        raise ValueError(
            f"a notification needs {count} flags and {count} sizes (one per parameter), "
            f"got {len(flags)} and {len(sizes)}"
        )
    total = sum(sizes)
    if not (total < math.inf and min(sizes) >= 0.0):  # the sum is NaN or inf if any size is
        raise ValueError(f"notification sizes {list(sizes)!r} must be finite and >= 0")
    if not level.shows_flags or not any(flags):
        return no_change, no_change
    shown_flags = tuple([1 if f else 0 for f in flags])
    if not level.shows_sizes:
        return shown_flags, no_change
    return shown_flags, tuple([float(s) for s in sizes])


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
