"""Robust backward induction against a bounded nature on the slip probability.

**Shape assumption.** The grid families' θ are slip vectors ``[p, rest...]`` whose first
element ``p`` is the probability of the intended move. Every distribution rule nature uses
(NS-Gym's and ns_pz's increment / decrement rules) splits ``1 - p`` equally over the other
outcomes, so nature moves along the line ``θ(p) = [p, (1-p)/(n-1), ..., (1-p)/(n-1)]``
(FrozenLake and Bridge: ``n = 3``, CliffWalking: ``n = 4``). On that line the total-variation
distance the ns_pz constraints measure is ``|p - p'|``, so a Lipschitz bound ``L`` per step and
an episode budget ``B`` confine ``p_t`` to ``[p_0 - r_t, p_0 + r_t]`` with
``r_t = min(L · (number of nature moves up to t), B)``, intersected with ``[low, high]``.

**Backup.** ``Q_t(s, a)`` is affine in θ, so its minimum over the convex hull of a few θ
("vertices") is reached at a vertex. :func:`robust_backward_induction` computes::

    V_t(s) = max_a min_j Σ_k P_{θ^j_t}(k | s, a) · (r_k + γ (1 - terminal_k) V_{t+1}(s'_k))

Nature may pick its vertex per (state, action, step), a superset of any one θ_t shared by all
states, so ``V_0`` is a lower bound: by induction on ``t``, the robust policy's value against any
nature whose θ_t lies in the hull at every step is ``>= V_t`` (its backup uses a θ inside the
hull, whose value is at least the minimum over the vertices). The vertices at step ``t`` are
``θ(lo_t)`` and ``θ(hi_t)``, plus θ_0 itself when θ_0 is not on the line and ``p_0`` lies in
the interval (nature may leave it unchanged); for off-line θ_0 the TV ball around θ_0 is inside
the ``|p - p_0| <= r_t`` interval used, so the bound stays valid, only less tight.

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
        if value is not None and not (math.isfinite(value) and value >= 0.0):
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
    """Robust solution against a nature that moves every slip vector's intended probability.

    Every probability-vector field of θ gets its own interval around its own ``p_0`` (see
    :func:`slip_intervals` for the arguments); the tail is split equally (module docstring).

    Raises:
        TypeError: ``family`` is not tabular, or ``theta0`` has no probability-vector field.
    """
    outcomes_fn = getattr(family, "outcomes", None)
    if not callable(outcomes_fn):
        raise TypeError(f"family={family!r} is not tabular (it has no outcomes(theta) table)")
    fields = [spec for spec in theta0.specs() if spec.kind == SIMPLEX]
    if not fields:
        raise TypeError(f"theta0={theta0!r} has no slip vector (probability-vector field)")
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


def _vertices(theta0: Params, bounds: dict[str, tuple[float, float]]) -> list[Params]:
    """θ at each vertex of one step: every slip field at its low end, its high end, and θ_0."""
    per_field: dict[str, list[tuple[float, ...]]] = {}
    for name, (lo, hi) in bounds.items():
        original = getattr(theta0, name)
        on_line = original == equal_split(original[0], len(original))
        if lo == hi == original[0]:
            options = [original]
        else:
            options = [equal_split(lo, len(original)), equal_split(hi, len(original))]
            if not on_line and lo <= original[0] <= hi:
                options.append(original)
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
