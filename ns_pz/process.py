"""The transition core shared by the AEC game, the Gymnasium view and the learner seats.

One :class:`NSProcess` runs one NS-MDP episode at a time, and is the one place where the order
of a time step lives. A time step ``t`` has three turns, which the process enforces:

1. ``nature`` (:meth:`NSProcess.nature_turn`): nature's proposal, projected onto the allowed
   set, becomes θ_t;
2. ``monitor`` (:meth:`NSProcess.monitor_turn`): the notification the agent gets, about the
   change behind the last transition (θ_{t-1} against θ_{t-2}): never about θ_t, which no one
   has seen act yet;
3. ``agent`` (:meth:`NSProcess.transition`): ``s_{t+1}`` is drawn under θ_t, ``t`` advances, and
   the turn is nature's again (unless the episode ended).

A turn taken out of order raises ``ValueError``. :meth:`NSProcess.play_until` plays the
configured nature and monitor (and, if given, a decision policy) until a chosen seat is to move:
the Gymnasium view calls it after every transition and at reset, the game when asked for a
policy's action, the learner environments of :mod:`ns_pz.learning.seats` to skip to their
learner's turn.
They therefore produce identical trajectories for the same seed and actions, for any nature and
any monitor, stateful or random.

Randomness: :meth:`NSProcess.seed` turns one seed into independent generators through
``numpy.random.SeedSequence``: the environment's (``Generator(PCG64(SeedSequence(seed)))``, which
is what Gymnasium's ``np_random`` would be), nature's, the monitor's, a seed sequence from which
each planning model gets a fresh child, and one for the policies driving seats (:meth:`seat_rng`).
No global generator is used anywhere.
"""

from __future__ import annotations

import copy
import math
import os
import sys
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple, cast

import numpy as np

from ns_pz.errors import ResetNeeded
from ns_pz.family import EnvFamily, State
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints, admit, remaining
from ns_pz.nature.interface import DEFAULT_STEP, NatureInterface
from ns_pz.nature.policies import Nature, Proposal, ScriptedNature, StaticNature
from ns_pz.observations import ObservationBuilder
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


NATURE = "nature"
"""Id of the seat that sets θ."""
MONITOR = "monitor"
"""Id of the seat that chooses the notification."""
DECISION = "agent"
"""Id of the decision maker's seat (the string ``"agent"``, as in PettingZoo)."""
AGENTS = (NATURE, MONITOR, DECISION)
"""The three seats, in turn order."""
RESET_OPTIONS = ("params",)


class EpisodeStart(NamedTuple):
    """What a reset starts from (:meth:`NSProcess.prepare_episode`)."""

    theta0: Params
    monitor_memory: Any
    explicit: bool = False
    """Whether the reset's options set θ_0 (then nature draws none)."""


class NSProcess:
    """One NS-MDP: a family, θ_0, nature, monitor, notification level, constraints, time limit.

    Args:
        family: The environment family.
        params: θ_0, as a parameter set or a mapping of names to values (others default).
        nature: Who changes θ (default: nobody, a stationary env).
        monitor: Who decides the notification (default: the oracle).
        notification: ``"none"``, ``"basic"`` or ``"detailed"``.
        constraints: Lipschitz bounds and budgets on nature.
        max_episode_steps: Transitions after which the episode is truncated; ``None``: never.

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
        self.base_theta0 = _check_params(family, params)
        """θ_0 of every episode that does not set its own (``reset(options={"params": ...})``)."""
        self.theta0 = self.base_theta0
        self.nominal_theta0 = self.base_theta0
        """θ_0 as the agent and its detectors know it: the episode's θ_0 unless nature drew a
        hidden one at reset (:class:`~ns_pz.nature.DomainRandomisation`)."""
        self.nature = StaticNature() if nature is None else nature
        if not isinstance(self.nature, Nature):
            raise TypeError(
                f"nature={nature!r} must be an ns_pz Nature (ScriptedNature, RandomNature, "
                "PolicyNature, ...)"
            )
        self.nature.bind(family.params_cls)
        self.monitor = OracleMonitor() if monitor is None else monitor
        if not isinstance(self.monitor, Monitor):
            raise TypeError(f"monitor={monitor!r} must be an ns_pz Monitor (e.g. OracleMonitor())")
        self.monitor.bind(family, self.base_theta0)
        self.level = NotificationLevel.parse(notification)
        self.constraints = NatureConstraints() if constraints is None else constraints
        if not isinstance(self.constraints, NatureConstraints):
            raise TypeError(f"constraints={constraints!r} must be a NatureConstraints")
        self.constraints.check_names(family.params_cls)
        if isinstance(self.nature, ScriptedNature):
            frozen = [name for name in self.nature.updates if not self.constraints.moves(name)]
            if frozen:
                raise ValueError(
                    f"nature schedules {frozen}, which constraints.movable="
                    f"{self.constraints.movable!r} freezes: add them to movable or drop their "
                    "updates"
                )
        if max_episode_steps is not None:
            if isinstance(max_episode_steps, bool) or not isinstance(
                max_episode_steps, (int, np.integer)
            ):
                raise TypeError(f"max_episode_steps={max_episode_steps!r} must be an int or None")
            if max_episode_steps < 1:
                raise ValueError(f"max_episode_steps={max_episode_steps!r} must be >= 1")
            max_episode_steps = int(max_episode_steps)
        self.max_episode_steps = max_episode_steps

        self.param_names = family.params_cls.names()
        self.no_change: tuple[float, ...] = (0.0,) * len(self.param_names)
        self._single_changes = {
            name: (
                tuple(1 if other == name else 0 for other in self.param_names),
                self.no_change[:i],
                self.no_change[i + 1 :],
            )
            for i, name in enumerate(self.param_names)
        }
        """Per parameter: the flags of a change of it alone, and the zero sizes before and
        after its own."""
        self.build = ObservationBuilder(family)
        self.env_rng: np.random.Generator | None = None
        self.nature_rng: np.random.Generator | None = None
        self.monitor_rng: np.random.Generator | None = None
        self._planning_seeds: np.random.SeedSequence | None = None
        self._seat_seeds: np.random.SeedSequence | None = None
        self._interfaces: dict[tuple, NatureInterface] = {}
        self.started = False
        self.done = True
        self.ended = (False, False)
        """(terminated, truncated) of the last transition."""
        self.turn = NATURE
        """Whose turn it is: ``"nature"``, ``"monitor"`` or ``"agent"``."""
        self.state: State = None
        self.initial_state: State = None
        """The start state of this episode."""
        self.theta = self.theta0
        self.last_theta = self.theta0
        """θ that drove the last transition (θ_0 before the first)."""
        self.t = 0
        self.last_action: Any = None
        self.last_reward = 0.0
        self.last_state: State = None
        self.last_change: tuple[Params, Params] | None = None
        """(θ before, θ after) of the change behind the last transition, if there was one."""
        self._quiet = (self.no_change, self.no_change)
        self.notice: tuple[tuple, tuple] = self._quiet
        """The notification of this step (flags, sizes), masked to the level; zeros until the
        monitor's turn and after the episode ends."""
        self._told_by_monitor = True  # False once a notification comes from outside
        self._start_memory: Any = None
        """A planning copy's monitor memory at the copy, which its own episodes start from
        (``None``: the monitor's :meth:`~ns_pz.monitor.Monitor.initial_memory`)."""
        self.spent: dict[str, float] = {}
        """Change size charged to nature's budget per parameter this episode (nothing is
        charged when no budget applies)."""
        self.change_times: list[int] = []
        self.change_values: list[Params] = []
        self.nature_memory: Any = None
        self.monitor_memory: Any = None
        self.carried_nature_memory: Any = None
        """Set before a reset to continue nature's memory in the next episode instead of starting
        afresh (NS-Gym's persistent parameters); consumed by that reset."""
        self._pending: tuple[int, Any] | None = None
        self._step_sizes: dict[str, float] | None = None
        self._last_sizes: dict[str, float] | None = None

    # -- seeding and reset ------------------------------------------------------------------
    def seed(self, seed: int | np.random.SeedSequence | None) -> None:
        """Derive every generator from one seed (``None``: fresh OS entropy).

        Raises:
            TypeError / ValueError: ``seed`` is not ``None``, a non-negative int or a
                ``SeedSequence``.
        """
        if not isinstance(seed, np.random.SeedSequence):
            seed = np.random.SeedSequence(check_seed(seed))
        self.env_rng = np.random.Generator(np.random.PCG64(seed))
        nature_seq, monitor_seq, planning_seq, seat_seq = seed.spawn(4)
        self.nature_rng = np.random.Generator(np.random.PCG64(nature_seq))
        self.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        self._planning_seeds = planning_seq
        self._seat_seeds = seat_seq

    def prepare_episode(self, options: Mapping[str, Any] | None = None) -> EpisodeStart:
        """Check a reset's ``options`` and what they start, changing nothing.

        Drivers that reseed at reset call this first, so a refused reset leaves the running
        episode and its generators as they were; :meth:`reset` then takes the result.

        Raises:
            TypeError: ``options`` is not a mapping.
            ParamOutOfRange / UnknownParam: An invalid θ_0.
            ValueError: The monitor cannot serve an episode from this θ_0 (a detector bound
                to another).
        """
        theta0 = self.base_theta0
        if options is not None:
            if not isinstance(options, Mapping):
                raise TypeError(f"options={options!r} must be a dict or None")
            unknown = sorted(map(str, set(options) - set(RESET_OPTIONS)))
            if unknown:
                warnings.warn(
                    f"reset options {unknown} are not understood and were ignored; "
                    f"understood: {list(RESET_OPTIONS)}",
                    UserWarning,
                    stacklevel=_caller_outside_libraries(),
                )
            if options.get("params") is not None:
                theta0 = _check_params(self.family, options["params"])
                if not (theta0 is self.base_theta0 or theta0 == self.base_theta0):
                    return EpisodeStart(theta0, self.monitor.episode_memory(theta0), True)
                return self._default_start(explicit=True)
        return self._default_start(explicit=False)

    def _default_start(self, explicit: bool) -> EpisodeStart:
        monitor = self.monitor
        if self._start_memory is not None:  # a planning copy's episode
            return EpisodeStart(self.base_theta0, copy.deepcopy(self._start_memory), explicit)
        return EpisodeStart(self.base_theta0, monitor.initial_memory(), explicit)

    def reset(
        self, options: Mapping[str, Any] | None = None, *, prepared: EpisodeStart | None = None
    ) -> None:
        """Start an episode: θ back to θ_0, a start state drawn, the clock at 0, nature to move.

        Args:
            options: ``{"params": θ_0}`` starts this episode (only) from another θ_0, a
                parameter set or a mapping of names to values (others default). Other keys are
                ignored with a warning that names them (PettingZoo's ``api_test`` passes one).
            prepared: What :meth:`prepare_episode` made of these ``options``, if called already.

        Raises:
            TypeError: ``options`` is not a mapping.
            ParamOutOfRange / UnknownParam: An invalid θ_0.
            ValueError: The monitor cannot serve an episode from this θ_0 (a detector bound
                to another).
        """
        start = prepared or self.prepare_episode(options)
        theta0 = self.nominal_theta0 = start.theta0
        if self.env_rng is None:
            self.seed(None)
        if not start.explicit:  # domain randomisation: nature's hidden draw of θ_0
            drawn = self.nature.initial_params(theta0, cast(np.random.Generator, self.nature_rng))
            if drawn is not None:
                theta0 = _check_params(self.family, drawn)
        self.state = self.family.initial_state_under(
            theta0, cast(np.random.Generator, self.env_rng)
        )
        self.initial_state = self.state
        self.theta0 = self.theta = self.last_theta = theta0
        self.t = 0
        self.last_action = None
        self.last_reward = 0.0
        self.last_state = self.state
        self.last_change = None
        self._step_sizes = self._last_sizes = None
        self.notice = (self.no_change, self.no_change)
        self._told_by_monitor = True
        self.spent = {}
        self.change_times = []
        self.change_values = []
        carried, self.carried_nature_memory = self.carried_nature_memory, None
        self.nature_memory = self.nature.initial_memory() if carried is None else carried
        self.monitor_memory = start.monitor_memory
        self._pending = None
        self.started = True
        self.done = False
        self.ended = (False, False)
        self.turn = NATURE

    def check_running(self, what: str) -> None:
        """Raise :class:`ResetNeeded` unless an episode is running."""
        if not self.started:
            raise ResetNeeded(f"{what} called before reset(); call reset() first")
        if self.done:
            raise ResetNeeded(f"{what} called after the episode ended; call reset() first")

    def check_turn(self, seat: str, what: str) -> None:
        """Raise unless an episode is running and it is ``seat``'s turn.

        Raises:
            ResetNeeded: No episode is running.
            ValueError: It is another seat's turn.
        """
        if self.done or self.turn != seat:
            self.check_running(what)
            raise ValueError(f"{what}: it is {self.turn!r}'s turn, not {seat!r}'s")

    # -- the three turns --------------------------------------------------------------------
    @property
    def budget_left(self) -> float:
        """What remains of the shared total budget this episode (``inf`` when there is none).

        Per-parameter and normalised budgets are in :attr:`spent` and the constraints.
        """
        budget = self.constraints.total_budget
        if budget is None:
            return math.inf
        return remaining(budget, math.fsum(self.spent.values()))

    def scripted_proposal(self) -> Proposal:
        """What the configured nature proposes this turn.

        Asked once per turn: a second call in the same turn returns the first answer, so the
        schedule and nature's generator advance once per step however often it is asked.

        Raises:
            ResetNeeded / ValueError: No episode is running, or it is not nature's turn.
        """
        self.check_turn(NATURE, "the nature policy's action")
        answer = self._answered()
        if answer is not _UNASKED:
            return cast(Proposal, answer)
        proposal = self.nature.act(self)
        self._pending = (self.t, proposal)
        return proposal

    def _answered(self) -> Any:
        """What the configured policy already answered in this turn, or :data:`_UNASKED`."""
        pending = self._pending
        if pending is not None and pending[0] == self.t:
            return pending[1]
        return _UNASKED

    def nature_turn(self, proposal: Mapping[str, Any] | None) -> None:
        """Grant nature's proposal for step ``t``, projected onto the allowed set.

        Raises:
            ResetNeeded / ValueError: No episode is running, or it is not nature's turn.
        """
        self.check_turn(NATURE, "nature's turn")
        self._grant(proposal)

    def _grant(self, proposal: Mapping[str, Any] | None) -> None:
        """Nature's turn, once it is known to be nature's turn (:meth:`nature_turn`)."""
        self._pending = None
        self.turn = MONITOR
        if not proposal:
            return
        theta, sizes = admit(
            self.theta,
            proposal,
            self.constraints,
            self.spent,
            sizes_wanted=self.level is not _NONE,  # the notification's
        )
        if theta is self.theta:
            return
        if sizes is not None and self.constraints.has_budget:
            spent = self.spent
            for name, size in sizes.items():
                spent[name] = spent.get(name, 0.0) + size
        self._record_change(theta, sizes)

    def scripted_notification(self) -> tuple[tuple, tuple]:
        """What the configured monitor says this turn, masked to the level.

        Asked once per turn: a second call in the same turn returns the first answer.

        Raises:
            ResetNeeded / ValueError: No episode is running, or it is not the monitor's turn.
        """
        self.check_turn(MONITOR, "the monitor policy's action")
        answer = self._answered()
        if answer is not _UNASKED:
            return cast(tuple, answer)
        notice = self._monitor_says()
        self._pending = (self.t, notice)
        return notice

    def _monitor_says(self) -> tuple[tuple, tuple]:
        level = self.level
        if level is _NONE:
            return self.no_change, self.no_change
        monitor = self.monitor
        if type(monitor) is OracleMonitor:  # its notification is the truth: no checks needed
            if self.last_change is None:
                return self.no_change, self.no_change
            return self._oracle_notice(level is _DETAILED)
        told: tuple[float, ...] | None = None  # the true sizes, for monitors that read them
        if monitor.reads_ground_truth:
            if self.last_change is None and monitor.quiet_without_change:
                return self.no_change, self.no_change
            told = self.last_sizes()
        observation = self.build.monitor(self) if monitor.needs_observation else None
        flags, sizes = monitor.notify(
            observation,
            told,
            self.monitor_memory,
            self.monitor_rng,  # type: ignore[arg-type]
        )
        return mask_notification(level, flags, sizes, self.no_change)

    def _oracle_notice(self, with_sizes: bool) -> tuple[tuple, tuple]:
        """The true notification of the last transition's change (there was one)."""
        nothing = self.no_change
        sizes = self._last_sizes
        if sizes is not None and len(sizes) == 1:  # one parameter changed: the usual case
            for name, size in sizes.items():
                if not size > 0.0:
                    return nothing, nothing
                flags, before, after = self._single_changes[name]
                if not with_sizes:
                    return flags, nothing
                return flags, before + (size,) + after
        truth = self.last_sizes()
        flags = tuple([1 if size > 0.0 else 0 for size in truth])
        if 1 not in flags:
            return nothing, nothing
        return flags, truth if with_sizes else nothing

    def monitor_turn(self, flags: Sequence[Any], sizes: Sequence[Any]) -> None:
        """Send the notification of this step (masked to the level) and give the agent the turn.

        Raises:
            ResetNeeded / ValueError: No episode is running, or it is not the monitor's turn.
            ValueError: ``flags``/``sizes`` do not have one entry per parameter, or a size is
                negative or not finite.
        """
        self.check_turn(MONITOR, "the monitor's turn")
        self.notice = mask_notification(self.level, flags, sizes, self.no_change)
        self._told_by_monitor = False  # the configured monitor's knowledge is not the sender's
        self._pending = None
        self.turn = DECISION

    def set_params(self, changes: Mapping[str, Any]) -> None:
        """Change θ now, by hand: validated strictly (no projection), applies to transition ``t``.

        Recorded in the ground truth and notified like a change by nature; not charged to
        nature's budget. Setting θ back, in the same step, to the θ of the last transition
        removes the step's change (nature's included, whose budget stays charged: nature did
        spend it).

        Raises:
            UnknownParam: A name is not a parameter.
            ParamOutOfRange: A value is invalid.
        """
        theta = self.theta.replace(**changes)
        if theta != self.theta:
            self._record_change(theta)

    def _record_change(self, theta: Params, sizes: dict[str, float] | None = None) -> None:
        """Make ``theta`` the θ in force; log it as the change at step ``t`` (one per step).

        A second change in the same step replaces the first; one back to the θ of the last
        transition removes it (the transition to come runs under an unchanged θ).

        ``sizes``: the change's size per changed parameter, if known (saves recomputing them
        for the notification; a second change in the same step forgets them).
        """
        self.theta = theta
        if self.change_times and self.change_times[-1] == self.t:
            if theta == self.last_theta:  # changed back within the step: no change at all
                self.theta = self.last_theta
                self.change_times.pop()
                self.change_values.pop()
            else:
                self.change_values[-1] = theta
            self._step_sizes = None
        else:
            self.change_times.append(self.t)
            self.change_values.append(theta)
            self._step_sizes = sizes

    @property
    def last_change_sizes(self) -> Mapping[str, float] | None:
        """The size of each parameter's change behind the last transition, by name.

        As nature's change recorded them (every changed parameter); ``None`` if there was no
        change or its sizes were not computed (level ``none``, a change by hand).
        """
        sizes = self._last_sizes
        return None if self.last_change is None or sizes is None else MappingProxyType(sizes)

    def last_sizes(self) -> tuple[float, ...]:
        """True size of each parameter's change behind the last transition (zeros if none)."""
        if self.last_change is None:
            return self.no_change
        sizes = self._last_sizes
        if sizes is not None:
            return tuple(map(sizes.get, self.param_names, self.no_change))
        before, after = self.last_change
        return after.change_sizes(before)

    def transition(
        self, action: Any, outcome: tuple[State, float, bool] | None = None
    ) -> tuple[float, bool, bool]:
        """The agent's turn: draw the next state under the current θ and advance the clock.

        ``action`` must already be checked (``family.check_action``). ``outcome``, if given, is
        ``(next state, reward, terminal)`` already drawn under the current θ by a batched copy of
        the family's dynamics (:mod:`ns_pz.vector`); the process then only does the bookkeeping.

        Returns:
            ``(reward, terminated, truncated)``.

        Raises:
            ResetNeeded / ValueError: No episode is running, or it is not the agent's turn.
        """
        if self.turn != DECISION or self.done:
            self.check_turn(DECISION, "the agent's turn")
        self.last_state = self.state
        if outcome is None:
            outcome = self.family.step(
                self.state,
                action,
                self.theta,
                self.env_rng,  # type: ignore[arg-type]
            )
        self.state, reward, terminated = outcome
        self.last_action = action
        self.last_reward = reward
        theta = self.theta
        if theta is self.last_theta:
            self.last_change = None
        else:
            self.last_change = (self.last_theta, theta)
            self.last_theta = theta
            self._last_sizes = self._step_sizes
            self._step_sizes = None
        self.t += 1
        limit = self.max_episode_steps
        truncated = limit is not None and self.t >= limit
        self.ended = (bool(terminated), truncated)
        self.done = terminated or truncated
        self.turn = NATURE
        self.notice = self._quiet  # until the monitor's turn of the next step
        return reward, terminated, truncated

    def play_until(
        self, seat: str | None, decide: Callable[[NSProcess], Any] | None = None
    ) -> tuple[float, int]:
        """Play the configured policies until it is ``seat``'s turn or the episode ends.

        Nature plays the configured nature, the monitor the configured monitor; the agent's turn
        is played by ``decide(process)`` (an action, checked here), and is where play stops if
        ``decide`` is ``None``. ``seat=None`` plays to the end of the episode. This is the one
        loop every driver of the process uses.

        Returns:
            The sum of the agent's rewards over the transitions played, and their number.
        """
        if seat is DECISION and self.turn is NATURE and self._pending is None and not self.done:
            # What every step of the view asks: nature's turn and the monitor's, unrolled.
            self._grant(self.nature.act(self))
            self.notice = self._monitor_says()
            self._told_by_monitor = True
            self.turn = DECISION
            return 0.0, 0
        total, count = 0.0, 0
        while not self.done and self.turn != seat:
            turn = self.turn
            # An answer already given this turn is the one played; otherwise the policy is asked
            # here, once (without the turn checks and caching of scripted_proposal/notification).
            answer: Any = _UNASKED if self._pending is None else self._answered()  # None: usual
            if turn == NATURE:
                self._grant(self.nature.act(self) if answer is _UNASKED else answer)
            elif turn == MONITOR:  # monitor_turn without re-checking the masked notification
                self.notice = self._monitor_says() if answer is _UNASKED else answer
                self._told_by_monitor = True
                self._pending = None
                self.turn = DECISION
            elif decide is None:
                return total, count
            else:
                reward, _, _ = self.transition(self.family.check_action(decide(self)))
                total += float(reward)
                count += 1
        return total, count

    def agent_observation(self) -> dict[str, Any]:
        """The decision agent's observation now: state, the notification of this step, clock."""
        flags, sizes = self.notice
        return self.build.agent(self.state, self.t, flags, sizes, self.no_change)

    def nature_interface(
        self,
        action: str = "delta",
        observes_state: bool = False,
        default_step: float = DEFAULT_STEP,
    ) -> NatureInterface:
        """Nature's observation and action conventions for this process (one per option set)."""
        key = (action, observes_state, default_step)
        interface = self._interfaces.get(key)
        if interface is None:
            interface = NatureInterface(
                self.family,
                self.base_theta0,
                self.constraints,
                self.max_episode_steps,
                action=action,
                observes_state=observes_state,
                default_step=default_step,
            )
            self._interfaces[key] = interface
        return interface

    def seat_rng(self) -> np.random.Generator:
        """A fresh generator for a policy driving a seat, from the seed (deterministic sequence).

        Raises:
            ResetNeeded: Called before the process was seeded.
        """
        if self._seat_seeds is None:
            raise ResetNeeded("seat policies need a seeded episode; call reset() first")
        return np.random.Generator(np.random.PCG64(self._seat_seeds.spawn(1)[0]))

    # -- what agents may be handed ----------------------------------------------------------
    def planning_theta(self) -> Params:
        """θ the agent's planning model assumes: θ_0, or at ``detailed`` the latest θ it knows.

        At ``detailed`` the exact oracle tells the θ behind the last transition (never one
        nature has chosen for a transition still to come: in the game the agent plans after
        nature's turn, and must not see it); an imperfect oracle, the parameters it has reported
        changed at their reported values (:meth:`~ns_pz.monitor.Monitor.told_changes`); a
        detector what it believes (:meth:`~ns_pz.monitor.Monitor.believed_theta`, θ_0 if it
        believes nothing yet); a notification sent by someone else than the configured monitor
        (the monitor seat played from outside), nothing: θ_0. A planner is never handed more
        than its monitor knows.
        """
        known = self.nominal_theta0
        if not self.level.shows_sizes:
            return known
        if not self._told_by_monitor:  # someone else's notification: nothing more than θ_0
            return known
        monitor = self.monitor
        if monitor.reads_ground_truth:
            told = monitor.told_changes(self.monitor_memory)
            names = self.param_names
            if told is None:  # every change up to the last transition
                if known is self.theta0:
                    return self.last_theta
                last = self.t - 1
                told = {i: last for i, name in enumerate(names) if self.changed_by(name, last)}
            return known.replace(
                **{names[i]: getattr(self.theta_at(at), names[i]) for i, at in told.items()}
            )
        believed = monitor.believed_theta(self.monitor_memory)
        return known if believed is None else believed

    def changed_by(self, name: str, transition: int) -> bool:
        """Whether a change of this episode up to transition ``transition`` moved ``name``."""
        previous = self.theta0
        for when, value in zip(self.change_times, self.change_values, strict=True):
            if when > transition:
                break
            if getattr(value, name) != getattr(previous, name):
                return True
            previous = value
        return False

    def theta_at(self, transition: int) -> Params:
        """The θ transition ``transition`` of this episode ran under (θ_0 for ``-1``)."""
        theta = self.theta0
        for when, value in zip(self.change_times, self.change_values, strict=True):
            if when > transition:
                break
            theta = value
        return theta

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
            raise ResetNeeded(_COPY_BEFORE_RESET)
        twin = copy.copy(self)
        theta = self.planning_theta() if theta is None else theta
        twin.base_theta0 = twin.theta0 = twin.nominal_theta0 = twin.theta = twin.last_theta = theta
        twin.nature = _STATIC
        twin.nature_memory = None
        twin.constraints = _UNCONSTRAINED
        # Own streams, so using the twin never touches ours; its static nature draws nothing.
        root = self._spawn_planning_seed()
        monitor_seq, planning_seq, seat_seq = root.spawn(3)
        twin.env_rng = np.random.Generator(np.random.PCG64(root))
        twin.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        twin.nature_rng = twin.env_rng
        twin._planning_seeds = planning_seq
        twin._seat_seeds = seat_seq
        twin._take_monitor_memory(self)
        twin.last_change = None
        twin._step_sizes = twin._last_sizes = None
        twin.change_times = []
        twin.change_values = []
        twin.spent = {}
        twin._interfaces = {}
        return twin._joined()

    def continuing_copy(
        self, theta: Params | None = None, *, retake_turn: bool = False
    ) -> NSProcess:
        """A process at the current state and time in which nature keeps acting.

        Args:
            theta: The θ the copy continues from (and starts its own episodes with); default
                :meth:`planning_theta`.
            retake_turn: If nature has already moved in this step, let it move again in the copy
                from ``theta`` (with its memory as it is now, so a rule that counts its firings
                counts this step twice); by default the copy's coming transition runs under
                ``theta`` and nature acts again from the next step.

        Nature's episode memory and the budget used are copied, so the schedule carries on
        where it is; the copy draws from fresh generators derived from the planning seed, so
        using it never touches this process's streams, and two copies differ.
        """
        if not self.started:
            raise ResetNeeded(_COPY_BEFORE_RESET)
        twin = copy.copy(self)
        theta = self.planning_theta() if theta is None else theta
        twin.base_theta0 = twin.theta0 = twin.nominal_theta0 = twin.theta = twin.last_theta = theta
        twin.nature_memory = copy.deepcopy(self.nature_memory)
        root = self._spawn_planning_seed()
        nature_seq, monitor_seq, planning_seq, seat_seq = root.spawn(4)
        twin.env_rng = np.random.Generator(np.random.PCG64(root))
        twin.nature_rng = np.random.Generator(np.random.PCG64(nature_seq))
        twin.monitor_rng = np.random.Generator(np.random.PCG64(monitor_seq))
        twin._planning_seeds = planning_seq
        twin._seat_seeds = seat_seq
        twin._take_monitor_memory(self)
        twin.last_change = None
        twin._step_sizes = twin._last_sizes = None
        twin.change_times = []
        twin.change_values = []
        twin.spent = dict(self.spent)
        if retake_turn and not self.done:
            twin.turn = NATURE
        return twin._joined()

    def _take_monitor_memory(self, original: NSProcess) -> None:
        """A copy's monitor starts from what ``original``'s knows now, and so do its episodes.

        That is :meth:`~ns_pz.monitor.Monitor.copy_memory`: a detector's belief, nothing for a
        monitor that reads the ground truth. A copy at another θ than the one a detector
        believes (planning at θ_0 below ``detailed``, ``branch(theta=...)``) gets a detector
        whose reference is the copy's θ where the detector can take one
        (:meth:`~ns_pz.monitor.Monitor.episode_memory`): believing another θ, it would report
        the difference as changes that never happen in the copy.
        """
        monitor, memory = self.monitor, original.monitor_memory
        start = None
        if not monitor.reads_ground_truth:
            believed = monitor.believed_theta(memory)
            if believed is not None and believed != self.theta0:
                try:
                    rebased = monitor.episode_memory(self.theta0)
                except ValueError:  # bound to its θ_0 (its belief adapts as data come)
                    rebased = None
                if rebased is not None and monitor.believed_theta(rebased) == self.theta0:
                    start = rebased  # (a monitor whose episode_memory ignores θ is not re-based)
        if start is None:
            start = monitor.copy_memory(memory)
        self._start_memory = start
        self.monitor_memory = copy.deepcopy(start)

    def _joined(self) -> NSProcess:
        """This copy, brought to the agent's turn (where a planner or a view takes over)."""
        self._pending = None
        self.notice = (self.no_change, self.no_change)
        if not self.done:
            self.play_until(DECISION)
        return self

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


_NONE = NotificationLevel.NONE
_DETAILED = NotificationLevel.DETAILED
"""The levels compared at every step (a global is read faster than an Enum's attribute)."""
_STATIC = StaticNature()
_COPY_BEFORE_RESET = (
    "get_planning_env() or branch() called before reset(); call reset() first (a planning copy "
    "starts from the current state of an episode)"
)
_UNASKED = object()
"""No answer of a configured policy is pending in this turn (``None`` is a valid proposal)."""
_UNCONSTRAINED = NatureConstraints()


def mask_notification(
    level: NotificationLevel, flags: Sequence[Any], sizes: Sequence[Any], no_change: tuple
) -> tuple[tuple, tuple]:
    """Keep what the level shows of a notification, after checking it.

    A size is shown only with its flag: sizes of unflagged parameters become 0.

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
    # A size speaks of a flagged change: an unflagged parameter's is not shown (as no flags at
    # all show no sizes).
    return shown_flags, tuple([float(s) if f else 0.0 for f, s in zip(flags, sizes, strict=True)])


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


def _caller_outside_libraries() -> int:
    """``stacklevel`` for a warning raised by this function's caller: the user's frame.

    The first frame outside ns_pz and the libraries that wrap its envs (Gymnasium's wrappers,
    PettingZoo's), so the warning names the user's line whichever way the reset was reached.
    """
    files = (getattr(sys.modules.get(name), "__file__", None) for name in _WRAPPING_PACKAGES)
    skipped = tuple(os.path.dirname(file) + os.sep for file in files if file)
    level = 2  # the caller of the function that warns
    frame: Any = sys._getframe(level)
    while frame is not None and frame.f_code.co_filename.startswith(skipped):
        level, frame = level + 1, frame.f_back
    return level


_WRAPPING_PACKAGES = ("ns_pz", "ns_pz.envs", "ns_pz.agents", "gymnasium", "pettingzoo")
"""Packages whose frames a warning about the user's call skips (those loaded)."""


def check_seed(seed: Any) -> int | None:
    """Return ``seed`` if it is ``None`` or a non-negative int, else raise.

    Raises:
        TypeError: ``seed`` is not an int (a bool or a float is refused too).
        ValueError: ``seed`` is negative.
    """
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed={seed!r} must be a non-negative int or None")
    if seed < 0:
        raise ValueError(f"seed={seed!r} must be a non-negative int or None")
    return int(seed)
