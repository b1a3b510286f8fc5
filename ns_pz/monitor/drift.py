"""Change detection on continuous families: CUSUM on the θ_0 model's one-step prediction error.

The detector predicts each observed transition with the family's planning model under its
reference θ (θ_0 until a change is detected): ``ŝ' = model.transition(s, a)``. The families
are deterministic, so under the reference the prediction is exact but for rounding: the monitor
sees float32 observations, and stepping from a rounded state gives an error of about ``1e-7``
relative. The statistic is therefore the prediction error in units of a tolerance that sits
well above rounding and well below what a real change of θ does in one step::

    x_t = max_i |ŝ'_i - s'_i| / (tolerance * (1 + |s'_i|)),

and a one-sided CUSUM with reference value 1 accumulates it: ``S_t = max(0, S_{t-1} + x_t - 1)``,
with an alarm when ``S_t > threshold``. A NaN error (a NaN observation, or a prediction that
overflows) counts as infinite: an alarm at once. An error below the tolerance only drains the
sum, so a stationary deterministic env raises no alarm; a gross change crosses at its first
informative transition; a small persistent one accumulates over several.

Why not river's Page–Hinkley or ADWIN: both learn the pre-change level from the stream and need
a warm-up (``min_instances``, a window on each side of the cut); in the shipped settings the
change hits the second transition, so there is no pre-change stream to learn from. Here the
pre-change behaviour is known exactly (the θ_0 model), which is what a CUSUM with a known
reference uses, in a dozen lines. Measured with river 0.26.1: on 0 then 300 ones (a step at
the second sample), neither ``PageHinkley(min_instances=1)`` nor ``ADWIN()`` flagged a drift;
``import river.drift`` took 0.85 s and loads scipy. (Its detectors would fit the per-episode
memory design, one fresh object per episode; the warm-up is what rules them out.)

When the CUSUM crosses, the detector fits θ to the transitions since the CUSUM last stood at
0 (the change-time estimate of a CUSUM): for each watched parameter, every value of a grid
(``θ × factor`` for the factors in ``factors``, kept inside the bounds) is scored by the sum of
the squared prediction errors of every observation entry over those transitions; each
parameter's best grid value is refined between its two grid neighbours by grids that zoom in
(each scored in one array call where the family has batched dynamics, :mod:`ns_pz.envs.batched`),
and the best refined (parameter, value) wins. The fit becomes the reference and the CUSUM
restarts.

One transition may not tell parameters apart (in CartPole near upright, a heavier pole and a
heavier cart predict the same step), so the first crossing opens a segment: its transitions
(the last ``window`` of them) accumulate, and a later crossing first refits θ from the θ in
force before the segment's alarm on all of them. If that fit predicts the crossing's
transitions within the tolerance, the crossing is a refinement, silent: the better fit becomes
the reference. Otherwise it is an alarm for a new change, and a new segment starts.

An alarm's notification flags the parameter the fit changed, with the change size between the
previous reference and the fit (or flags every parameter, size 0, if no fit predicts better).

A family whose observation is not its state provides ``state_from_observation(observation)
-> state`` (Pendulum and Acrobot read their angles back from cos/sin); families whose
observation is the state vector itself (CartPole, MountainCar) need nothing. Others
(MountainCarContinuous, whose state holds a flag the observation does not show) are refused
at :meth:`PredictionErrorMonitor.bind`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from ns_pz.checks import count, positive_number
from ns_pz.family import EnvFamily
from ns_pz.monitor.monitors import (
    Detector,
    Flags,
    Sizes,
    has_transition,
    silence,
    watched_names,
)
from ns_pz.params import SIMPLEX, Params

DEFAULT_FACTORS = tuple(
    sorted({float(f) for f in (*np.geomspace(0.1, 20.0, 61), *np.geomspace(0.9, 1.1, 21))})
)
"""Multiplicative grid of candidate values (θ_ref × factor): 0.1× to 20× in steps of about 9%,
and 0.9× to 1.1× in steps of 1% to refine an estimate at a later alarm."""
ZOOM_POINTS = 17
"""Values scored per round of the refinement between a best grid value's neighbours."""
ZOOM_ROUNDS = 6
"""Rounds of the refinement (each narrows the bracket eightfold)."""
_LARGEST = float(np.finfo(np.float64).max)


class PredictionErrorMemory:
    """One episode's detector state."""

    __slots__ = ("reference", "statistic", "recent", "base", "segment", "alarms", "trace")

    def __init__(self, reference: Params, window: int) -> None:
        self.reference = reference
        self.statistic = 0.0
        self.base = reference
        """θ in force before the current segment's alarm."""
        self.segment: deque[tuple[Any, Any, np.ndarray]] | None = None
        """Transitions since the last alarm's change-time estimate (``None`` before it)."""
        self.recent: deque[tuple[Any, Any, np.ndarray]] = deque(maxlen=window)
        """Transitions since the statistic was last 0, as (state, action, next observation)."""
        self.alarms: list[int] = []
        """Transition indices whose notification raised an alarm."""
        self.trace: list[float] = []
        """The CUSUM statistic after each transition (before a restart at an alarm)."""


class PredictionErrorMonitor(Detector):
    """CUSUM on the θ_0 planning model's one-step prediction error (see the module doc).

    Args:
        threshold: Alarm threshold of the CUSUM, in tolerance units.
        tolerance: Relative prediction error counted as noise.
        window: Most transitions a segment keeps to fit θ (see the module doc).
        factors: Multiplicative grid of candidate values for a scalar parameter.
        params: Names of the scalar parameters to watch and estimate; default every scalar one.

    Raises:
        ValueError: A non-positive threshold or tolerance, a window below 1, an empty or
            non-positive factor grid.
    """

    def __init__(
        self,
        threshold: float = 5.0,
        tolerance: float = 1e-4,
        window: int = 20,
        factors: Sequence[float] = DEFAULT_FACTORS,
        params: Sequence[str] | None = None,
    ) -> None:
        self.threshold = positive_number("threshold", threshold)
        self.tolerance = positive_number("tolerance", tolerance)
        window = count("window", window)
        if isinstance(factors, str) or not factors:
            raise ValueError(f"factors={factors!r} must be a non-empty list of finite numbers > 0")
        self.factors = tuple(positive_number("factors[...]", f) for f in factors)
        self.window = window
        self.watched = watched_names(params)
        self._names: tuple[str, ...] = ()
        self._kernel: Any = None
        self._columns: dict[str, int] = {}

    def bind(self, family: EnvFamily, theta0: Params) -> None:
        """Check the family's state can be read from its observation; pick the parameters.

        Raises:
            TypeError: The observation does not give the state back, and the family has no
                ``state_from_observation``.
            UnknownParam: A watched name is not a parameter.
            ValueError: A watched parameter is a probability vector; the dynamics are noisy;
                already bound to another family or θ_0.
        """
        if self._already_bound(family, theta0):
            return
        names = (
            tuple(s.name for s in family.params_cls.specs() if s.kind != SIMPLEX)
            if self.watched is None
            else self.watched
        )
        family.params_cls.check_names(names)
        for name in names:
            if family.params_cls.spec(name).kind == SIMPLEX:
                raise ValueError(
                    f"params: {name!r} is a probability vector; PredictionErrorMonitor estimates "
                    "scalar parameters (use TabularCusumMonitor on tabular families)"
                )
        rng = np.random.default_rng(0)
        state = family.initial_state(rng)
        observed = np.asarray(family.observe(state), np.float64)
        try:
            back = _state_of(family, observed)
            again = np.asarray(family.observe(back), np.float64)
            family.step(back, _any_action(family), theta0, rng)
        except Exception as error:  # noqa: BLE001 - any failure means the state is not readable
            raise TypeError(
                f"{family!r}: the state cannot be read from the observation ({error}). "
                "PredictionErrorMonitor replays transitions from observed states, so it serves "
                "families whose observation is their state (CartPole, Pendulum, MountainCar, "
                "Acrobot), not those whose observation leaves part of it out (the MuJoCo "
                "tasks); a family of your own can give a state_from_observation(observation) "
                "method"
            ) from None
        if again.shape != observed.shape or not np.allclose(again, observed, atol=1e-6):
            raise TypeError(
                f"{family!r}: observe(state) is not the state; give the family a "
                "state_from_observation(observation) method"
            )
        outcomes = {
            repr(family.step(back, _any_action(family), theta0, np.random.default_rng(seed)))
            for seed in range(4)
        }
        if len(outcomes) > 1:
            raise ValueError(
                f"{family!r} draws from its generator in step (noise); PredictionErrorMonitor "
                "predicts deterministic dynamics and would alarm at every transition"
            )
        self._family = family
        self._theta0 = theta0
        self._names = names
        self._kernel = _array_kernel(family)
        self._columns = {spec.name: start for spec, start, _ in family.params_cls.flat_layout()}

    def initial_memory(self) -> PredictionErrorMemory:
        """θ_0 as the reference, the CUSUM at 0."""
        return PredictionErrorMemory(self._bound_theta0(), self.window)

    def episode_memory(self, theta0: Params) -> PredictionErrorMemory:
        """The episode's own θ_0 as the reference (the model only needs a θ to predict with)."""
        return PredictionErrorMemory(theta0, self.window)

    def copy_memory(self, memory: PredictionErrorMemory) -> PredictionErrorMemory:
        """The belief alone, for a planning copy: its reference θ, the CUSUM at 0."""
        return PredictionErrorMemory(memory.reference, self.window)

    def believed_theta(self, memory: PredictionErrorMemory) -> Params:
        """θ_0 updated by every change detected so far."""
        return memory.reference

    def errors(
        self,
        theta: Params,
        state: Any,
        action: Any,
        observed: np.ndarray,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """Prediction error of each observation entry of one transition under ``theta``.

        Relative (``|ŝ' - s'| / (1 + |s'|)``) and in tolerance units. ``rng`` is what the
        model's step may draw from (the shipped continuous families draw nothing).
        """
        assert self._family is not None
        predicted, _, _ = self._family.step(state, action, theta, rng)
        guess = np.asarray(self._family.observe(predicted), np.float64)
        return np.abs(guess - observed) / (1.0 + np.abs(observed)) / self.tolerance

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Sequence[float] | None,
        memory: PredictionErrorMemory,
        rng: np.random.Generator,
    ) -> tuple[Flags, Sizes]:
        """Add the last transition's error to the CUSUM; estimate and flag at an alarm."""
        count = len(memory.reference.names())
        quiet = silence(count)
        if not has_transition(observation):
            return quiet
        assert observation is not None and self._family is not None
        state = _state_of(self._family, np.asarray(observation["last_state"], np.float64))
        action = observation["last_action"]
        observed = np.asarray(observation["state"], np.float64)
        memory.recent.append((state, action, observed))
        score = float(self.errors(memory.reference, state, action, observed, rng).max())
        if score != score:  # NaN: an observation (or a prediction) no θ explains is a change
            score = np.inf
        memory.statistic = max(0.0, memory.statistic + score - 1.0)
        memory.trace.append(memory.statistic)
        if memory.statistic == 0.0:
            memory.recent.clear()
        if not memory.statistic > self.threshold:
            return quiet
        old = memory.reference
        recent = list(memory.recent)
        alarm = True
        if memory.segment is not None:
            memory.segment.extend(recent)
            refit = self._estimate(memory.base, memory.segment, rng)
            worst = max(float(self.errors(refit, *t, rng).max()) for t in recent)
            if worst <= 1.0:
                alarm, new = False, refit
        if alarm:
            memory.alarms.append(int(observation["relative_time"][0]) - 1)
            memory.base = old
            memory.segment = deque(recent, maxlen=self.window)
            new = self._estimate(old, recent, rng)
        memory.reference = new
        memory.statistic = 0.0
        memory.recent.clear()
        if not alarm:
            return quiet
        before, after = old.as_dict(), new.as_dict()
        flags = tuple(int(before[name] != after[name]) for name in before)
        if not any(flags):  # no candidate explains the data better: report "something changed"
            return (1,) * count, (0.0,) * count
        sizes = new.change_sizes(old)
        return flags, tuple(float(s) if f else 0.0 for s, f in zip(sizes, flags, strict=True))

    def _estimate(
        self,
        reference: Params,
        transitions: Iterable[tuple[Any, Any, np.ndarray]],
        rng: np.random.Generator,
    ) -> Params:
        """``reference`` with the one (parameter, value) that best predicts ``transitions``.

        Every parameter's grid is scored in one batch; then each parameter's best grid value
        is refined between its two grid neighbours by :data:`ZOOM_ROUNDS` rounds of
        :data:`ZOOM_POINTS` evenly spaced values, every parameter in the same batch (a round
        narrows each bracket eightfold: to about 4e-6 of its first width at the end). Ties go
        to the first row scored.
        """
        data = list(transitions)
        names = self._names
        if not names or not data:
            return reference
        scorer = _Scorer(self, reference, data, rng)
        grids: dict[str, np.ndarray] = {}
        for name in names:
            base = float(getattr(reference, name))
            low, high = reference.spec(name).finite_range
            grid = self._candidates(base)
            grid = grid[(grid >= low) & (grid <= high) & (grid != base)]
            if len(grid):
                grids[name] = grid
        columns = self._columns
        first = names[0]
        now = float(getattr(reference, first))
        losses = scorer.losses(
            np.concatenate(
                [[columns[first]], *(np.full(len(grid), columns[n]) for n, grid in grids.items())]
            ),
            np.concatenate([[now], *grids.values()]),
        )
        best_loss, best = losses[0], (first, now)
        brackets: dict[str, tuple[float, float]] = {}
        at = 1
        for name, grid in grids.items():
            scores = losses[at : at + len(grid)]
            at += len(grid)
            i = int(np.argmin(scores))
            if scores[i] < best_loss:
                best_loss, best = scores[i], (name, float(grid[i]))
            low, high = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
            if low < high:
                brackets[name] = (float(low), float(high))
        zoomed = list(brackets)
        zoomed_columns = np.repeat([columns[name] for name in zoomed], ZOOM_POINTS)
        bounds = np.array(list(brackets.values()))
        rows = np.arange(len(zoomed))
        for _ in range(ZOOM_ROUNDS if brackets else 0):
            values = _linspaces(bounds, ZOOM_POINTS)
            scores = scorer.losses(zoomed_columns, values.reshape(-1)).reshape(len(zoomed), -1)
            picks = scores.argmin(axis=1)
            for k, i in enumerate(picks.tolist()):
                if scores[k, i] < best_loss:
                    best_loss, best = scores[k, i], (zoomed[k], float(values[k, i]))
            below = values[rows, np.maximum(picks - 1, 0)]
            above = values[rows, np.minimum(picks + 1, ZOOM_POINTS - 1)]
            bounds = np.stack([below, above], axis=1)
        name, value = best
        if value == getattr(reference, name):
            return reference
        return reference.replace(**{name: value})

    def _candidates(self, base: float) -> np.ndarray:
        """Grid values around ``base``, increasing (around 1 when ``base`` is 0)."""
        if base == 0.0:
            return np.array(
                sorted({f - 1.0 for f in self.factors} | {1.0 - f for f in self.factors})
            )
        return np.sort(base * np.array(self.factors))

    def __repr__(self) -> str:
        return (
            f"PredictionErrorMonitor(threshold={self.threshold}, tolerance={self.tolerance}, "
            f"window={self.window}, params={self.watched!r})"
        )


class _Scorer:
    """Squared prediction errors of one estimate's transitions under θ values, summed per value.

    A value is the reference θ with one parameter set; every (value, transition) pair is
    predicted in one array call where the family has a batched kernel
    (:mod:`ns_pz.envs.batched`), else one scalar step each. The transitions' arrays are built
    once per estimate, and their copies for a batch of a given size once per size.
    """

    def __init__(
        self,
        monitor: PredictionErrorMonitor,
        reference: Params,
        data: list[tuple[Any, Any, np.ndarray]],
        rng: np.random.Generator,
    ) -> None:
        self.monitor, self.reference, self.data, self.rng = monitor, reference, data, rng
        self.kernel = kernel = monitor._kernel
        self.tiled: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        if kernel is not None:
            self.states = np.array([kernel.pack(s) for s, _, _ in data], kernel.state_dtype)
            self.actions = np.array([a for _, a, _ in data])
            self.observed = np.stack([o for _, _, o in data])
            self.scale = 1.0 + np.abs(self.observed)
            self.theta = reference.flat()

    def losses(self, columns: np.ndarray, values: np.ndarray) -> np.ndarray:
        """One sum per row ``k``: the reference with ``columns[k]`` set to ``values[k]``.

        ``columns[k]`` is a scalar parameter's column in the flat θ (``Params.flat``). A NaN
        sum (a NaN observation or prediction) counts as infinite, an infinite one (a prediction
        that overflows) as the largest float, as ``np.nan_to_num(sums, nan=np.inf)`` does.
        """
        monitor, data, rng = self.monitor, self.data, self.rng
        kernel = self.kernel
        if kernel is None:
            named = {column: name for name, column in monitor._columns.items()}
            sums = np.array(
                [
                    sum(
                        float(np.sum(monitor.errors(self._theta(named[c], v), s, a, o, rng) ** 2))
                        for s, a, o in data
                    )
                    for c, v in zip(columns.tolist(), values.tolist(), strict=True)
                ]
            )
        else:
            count, steps = len(values), len(data)
            if count not in self.tiled:
                self.tiled[count] = (
                    np.tile(self.states, (count, *([1] * (self.states.ndim - 1)))),
                    np.tile(self.actions, (count, *([1] * (self.actions.ndim - 1)))),
                )
            states, actions = self.tiled[count]
            theta = np.empty((count, steps, len(self.theta)))
            theta[...] = self.theta
            theta[np.arange(count), :, columns] = values[:, None]
            predicted, _, _ = kernel.step(states, actions, theta.reshape(count * steps, -1), None)
            guess = np.asarray(kernel.observe(predicted), np.float64).reshape(count, steps, -1)
            errors = np.abs(guess - self.observed) / self.scale / monitor.tolerance
            sums = np.sum(errors * errors, axis=(1, 2))
        return np.where(np.isnan(sums), np.inf, np.minimum(sums, _LARGEST))

    def _theta(self, name: str, value: float) -> Params:
        return self.reference.replace(**{name: value})


def _linspaces(brackets: np.ndarray, points: int) -> np.ndarray:
    """``np.linspace(low, high, points)`` for each ``(low, high)`` row of ``brackets``.

    The same values as NumPy's, row by row (``k * step + low``, ``high`` last; ``k / div *
    delta + low`` in a row whose step is 0), computed for every row at once. ``points`` is at
    least 2.
    """
    low, high = brackets[:, :1], brackets[:, 1:]
    delta = high - low
    div = points - 1
    step = delta / div
    k = np.arange(points, dtype=np.float64)
    values = np.where(step == 0.0, k / div * delta, k * step) + low
    values[:, -1] = high[:, 0]
    return values


def _array_kernel(family: EnvFamily) -> Any:
    """The family's batched dynamics, if it has array kernels that draw nothing per step."""
    from ns_pz.envs.batched import kernel_for
    from ns_pz.vector import ArrayKernel

    kernel = kernel_for(family)
    if isinstance(kernel, ArrayKernel) and kernel.step_uniforms == 0:
        return kernel
    return None


def _state_of(family: EnvFamily, observation: np.ndarray) -> Any:
    convert = getattr(family, "state_from_observation", None)
    if convert is not None:
        return convert(observation)
    return tuple(float(x) for x in observation)


def _any_action(family: EnvFamily) -> Any:
    space = family.action_space
    if isinstance(space, spaces.Discrete):
        return int(space.start)
    return np.zeros(space.shape, space.dtype)
