"""Robust backward induction against a bounded nature on the slip probability.

**The natures covered.** The grid families' θ are slip vectors ``[p, rest...]`` whose first
element ``p`` is the probability of the intended move. :func:`robust_slip_solution` covers the
natures that keep every slip vector on the equal-split line
``θ(p) = [p, (1-p)/(n-1), ..., (1-p)/(n-1)]`` (FrozenLake and Bridge: ``n = 3``, CliffWalking:
``n = 4``), as ns_pz's and NS-Gym's increment / decrement rules and step-wise rules with
equal-split targets do, starting from a θ_0 on that line. On the line the total-variation
distance the ns_pz constraints measure is ``|p - p'|``, so a Lipschitz bound ``L`` per step and
an episode budget ``B`` confine ``p_t`` to ``[p_0 - r_t, p_0 + r_t]`` with
``r_t = min(L · (number of nature moves up to t), B)``, intersected with ``[low, high]``.

A nature that leaves the line is *not* covered, even within the same Lipschitz bound and
budget: on the Bridge (``L = 0.1``, ``B = 0.3``, five steps) the schedule ``(0.7, 0.15, 0.15) ->
(0.6, 0.15, 0.25) -> (0.5, 0.15, 0.35) -> (0.4, 0.25, 0.35)``, TV 0.1 per step, gets the robust
policy 0.044 below its guarantee from one state. Nor is a θ_0 off the line (from
``(0.7, 0.3, 0)`` with ``B = 0.3`` the old solver "guaranteed" 0.64 where ``(0.4, 0.6, 0)`` gets
0.496), so such a θ_0 is refused.

**Backup.** ``Q_t(s, a)`` is affine in θ, so its minimum over the convex hull of a few θ
("vertices") is reached at a vertex. :func:`robust_backward_induction` computes::

    V_t(s) = max_a min_j Σ_k P_{θ^j_t}(k | s, a) · (r_k + γ (1 - terminal_k) V_{t+1}(s'_k))

Nature may pick its vertex per (state, action, step), a superset of any one θ_t shared by all
states, so ``V_0`` is a lower bound: by induction on ``t``, the robust policy's value against any
nature whose θ_t lies in the hull at every step is ``>= V_t`` (its backup uses a θ inside the
hull, whose value is at least the minimum over the vertices). The vertices at step ``t`` are
``θ(lo_t)`` and ``θ(hi_t)``, whose segment is exactly where a covered nature can be. With
several slip fields (the split Bridge) each field has its own interval and the vertices put
every field at its low end, or every field at its high end; that suffices because each state's
outcomes follow one field only, so each (state, action) backup is affine in that one field.

This differs from RATS's nature (:mod:`ns_pz.agents.search.rats`), which moves the outcome
distribution of each (state, action) within a Wasserstein ball over the Manhattan metric on the
grid, without keeping the slip shape.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from ns_pz.agents.exact.induction import (
    FiniteHorizonSolution,
    backup,
    check_gamma,
    check_tables,
)
from ns_pz.agents.exact.schedule import check_horizon

from ns_pz.family import EnvFamily
from ns_pz.params import SIMPLEX, Params
from ns_pz.planning import TabularOutcomes


def robust_backward_induction(
    vertex_tables: Sequence[Sequence[TabularOutcomes]], gamma: float = 1.0
) -> FiniteHorizonSolution:
    """Max-min backward induction; nature picks, per (s, a, t), the worst of step t's tables.

    Args:
        vertex_tables: ``vertex_tables[t]``: the outcome tables of the vertices nature may
            choose among at step ``t`` (at least one; counts may differ between steps).
        gamma: Discount in ``[0, 1]``.

    Returns:
        The robust (guaranteed) values, the Q-values after nature's minimum, and the maximising
        policy (ties: lowest action index).
    """
    if isinstance(vertex_tables, (str, bytes)) or not isinstance(vertex_tables, Sequence):
        raise TypeError(f"vertex_tables={vertex_tables!r} must be a sequence (one per step)")
    if not vertex_tables:
        raise ValueError("vertex_tables=[] is empty; give the vertices of each step (horizon >= 1)")
    shape = check_tables([tables for step in vertex_tables for tables in _step_list(step)])
    gamma = check_gamma(gamma)
    horizon, (num_states, num_actions, _) = len(vertex_tables), shape
    values = np.zeros((horizon + 1, num_states))
    q_values = np.empty((horizon, num_states, num_actions))
    for t in range(horizon - 1, -1, -1):
        vertices = _step_list(vertex_tables[t])
        worst = backup(vertices[0], values[t + 1], gamma)
        for table in vertices[1:]:
            np.minimum(worst, backup(table, values[t + 1], gamma), out=worst)
        q_values[t] = worst
        values[t] = worst.max(axis=1)
    return FiniteHorizonSolution(values, q_values, q_values.argmax(axis=2), gamma)


def slip_intervals(
    p0: float,
    horizon: int,
    *,
    lipschitz: float | None = None,
    budget: float | None = None,
    low: float = 0.0,
    high: float = 1.0,
    first_change_step: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Where nature can have moved the intended probability by each step.

    Nature moves at steps ``first_change_step, first_change_step + 1, ...`` (its move at step
    ``t`` applies to transition ``t``), each by at most ``lipschitz``, in total at most
    ``budget``, always inside ``[low, high]``. Before ``first_change_step`` the interval is
    ``{p0}``.

    Returns:
        ``(lo, hi)``, each ``[horizon]``.

    Raises:
        ValueError: A bound is negative or not finite, ``low > high``, ``p0`` or the bounds lie
            outside ``[0, 1]``, or ``first_change_step < 0``.
    """
    horizon = check_horizon(horizon)
    p0 = _check_probability("p0", p0)
    low, high = _check_probability("low", low), _check_probability("high", high)
    if low > high:
        raise ValueError(f"low={low!r} must be <= high={high!r}")
    for name, value in (("lipschitz", lipschitz), ("budget", budget)):
        if value is not None and not (
            isinstance(value, (int, float, np.integer, np.floating))
            and not isinstance(value, bool)
            and math.isfinite(value)
            and value >= 0.0
        ):
            raise ValueError(f"{name}={value!r} must be a finite number >= 0 or None")
    if isinstance(first_change_step, bool) or not isinstance(first_change_step, int):
        raise TypeError(f"first_change_step={first_change_step!r} must be an int")
    if first_change_step < 0:
        raise ValueError(f"first_change_step={first_change_step!r} must be >= 0")
    moves = np.clip(np.arange(horizon) - first_change_step + 1, 0, None).astype(np.float64)
    radius = np.full(horizon, np.inf) if lipschitz is None else lipschitz * moves
    if budget is not None:
        radius = np.minimum(radius, budget)
    radius[moves == 0] = 0.0
    lo = np.where(moves == 0, p0, np.clip(p0 - radius, low, high))
    hi = np.where(moves == 0, p0, np.clip(p0 + radius, low, high))
    return lo, hi


def robust_slip_solution(
    family: EnvFamily,
    theta0: Params,
    horizon: int,
    *,
    lipschitz: float | None = None,
    budget: float | None = None,
    low: float = 0.0,
    high: float = 1.0,
    first_change_step: int = 0,
    gamma: float = 1.0,
) -> FiniteHorizonSolution:
    """Robust solution against natures that move slip vectors along the equal-split line.

    Guaranteed value: against every nature that keeps each slip vector equal-split,
    ``[p, (1-p)/(n-1), ...]``, and moves each field's ``p`` by at most ``lipschitz`` per move
    (from step ``first_change_step`` on), by at most ``budget`` in total and inside
    ``[low, high]``, the returned policy's expected value from state ``s`` before transition
    ``t`` is at least ``values[t, s]``. Natures that leave the line are not covered (module
    docstring). Every probability-vector field of θ gets its own interval around its own
    ``p_0`` (see :func:`slip_intervals` for the arguments).

    Raises:
        TypeError: ``family`` is not tabular, or ``theta0`` has no probability-vector field.
        ValueError: A slip vector of ``theta0`` is off the equal-split line.
    """
    outcomes_fn = getattr(family, "outcomes", None)
    if not callable(outcomes_fn):
        raise TypeError(f"family={family!r} is not tabular (it has no outcomes(theta) table)")
    fields = [spec for spec in theta0.specs() if spec.kind == SIMPLEX]
    if not fields:
        raise TypeError(f"theta0={theta0!r} has no slip vector (probability-vector field)")
    for spec in fields:
        _check_on_line(theta0, spec.name)
    intervals = {
        spec.name: slip_intervals(
            getattr(theta0, spec.name)[0],
            horizon,
            lipschitz=lipschitz,
            budget=budget,
            low=low,
            high=high,
            first_change_step=first_change_step,
        )
        for spec in fields
    }
    built: dict[Params, TabularOutcomes] = {}
    vertex_tables = []
    for t in range(horizon):
        vertices = _vertices(theta0, {name: (lo[t], hi[t]) for name, (lo, hi) in intervals.items()})
        step = []
        for theta in vertices:
            if theta not in built:
                built[theta] = outcomes_fn(theta)
            step.append(built[theta])
        vertex_tables.append(step)
    return robust_backward_induction(vertex_tables, gamma)


def equal_split(p: float, size: int) -> tuple[float, ...]:
    """``[p, (1-p)/(size-1), ...]``: a slip vector with the tail split equally."""
    return (p,) + ((1.0 - p) / (size - 1),) * (size - 1)


def _check_on_line(theta0: Params, name: str) -> None:
    """Refuse a slip vector of θ_0 off the equal-split line (up to rounding, 1e-12)."""
    vector = getattr(theta0, name)
    line = equal_split(vector[0], len(vector))
    if not np.allclose(vector, line, rtol=0.0, atol=1e-12):
        raise ValueError(
            f"theta0.{name}={vector!r} is off the equal-split line: robust_slip_solution "
            f"accepts only slip vectors [p, (1-p)/{len(vector) - 1}, ...] (here {line!r}), "
            "the line the natures it covers keep to; its guarantee does not hold off it"
        )


def _vertices(theta0: Params, bounds: dict[str, tuple[float, float]]) -> list[Params]:
    """θ at each vertex of one step: every slip field at its low end, or at its high end."""
    per_field: dict[str, list[tuple[float, ...]]] = {}
    for name, (lo, hi) in bounds.items():
        original = getattr(theta0, name)
        if lo == hi == original[0]:
            options = [original]
        else:
            options = [equal_split(lo, len(original)), equal_split(hi, len(original))]
        per_field[name] = options
    count = max(len(options) for options in per_field.values())
    return list(
        dict.fromkeys(  # same θ for several vertices: build its table once
            theta0.replace(
                **{name: opts[min(j, len(opts) - 1)] for name, opts in per_field.items()}
            )
            for j in range(count)
        )
    )


def _step_list(step: object) -> list[TabularOutcomes]:
    if isinstance(step, TabularOutcomes):
        return [step]
    if not isinstance(step, Sequence) or not step:
        raise ValueError(f"each step of vertex_tables needs >= 1 table, got {step!r}")
    return list(step)


def _check_probability(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={value!r} must be a real number in [0, 1]")
    if not 0.0 <= float(value) <= 1.0:
        raise ValueError(f"{name}={value!r} must lie in [0, 1]")
    return float(value)
