"""Nature's worst-case distribution at a RATS chance node.

Each function takes the snapshot distribution ``w0`` over a chance node's children, the
children's values ``v``, the ground-metric distances between the children (``distances[i][j]``,
``None`` for a nature that ignores the metric) and nature's budget ``c >= 0``, and returns the
distribution ``w`` nature plays. All are plain Python on short lists: a chance node has 3 or 4
children, where numpy's per-call overhead would dominate.

* :func:`dirac_support`: the Dirac on the lowest-valued child, whatever the budget (what the
  NS-Gym paper's RATS ran; even outcomes of probability 0 can be chosen);
* :func:`wasserstein_direct`: the "direct method" of Lecarpentier's released code, a feasible
  point of the Wasserstein ball (exact whenever the Dirac is affordable);
* :func:`wasserstein_lp`: the exact minimiser of ``w · v`` over the ball
  ``{w : W1(w0, w) <= c}``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

Vector = Sequence[float]
Matrix = Sequence[Sequence[float]]
WorstCaseFn = Callable[[Vector, Vector, "Matrix | None", float], list[float]]

BUDGET_ATOL = 1e-12
"""A budget at most this large counts as zero (the released code compares at ~1e-13)."""


def dirac_support(
    w0: Vector, values: Vector, distances: Matrix | None, budget: float
) -> list[float]:
    """All mass on the first child of least value, ignoring ``w0``, metric and budget."""
    worst = min(range(len(values)), key=values.__getitem__)
    return [1.0 if i == worst else 0.0 for i in range(len(values))]


def wasserstein_direct(
    w0: Vector, values: Vector, distances: Matrix | None, budget: float
) -> list[float]:
    """Lecarpentier's direct method: ``w0``, the Dirac on the worst child, or a mixture.

    Returns ``w0`` if the budget is (about) zero or every value is equal; the Dirac ``δ`` on the
    first child of least value if ``W1(w0, δ) <= budget``; otherwise ``(1 - λ) w0 + λ δ`` with
    ``λ = budget / W1(w0, δ)``, which lies on the ball's boundary (moving a fraction ``λ`` of
    every unit of mass to the worst child costs ``λ · W1(w0, δ)``). ``W1(w0, δ)`` is
    ``Σ_i w0_i d(i, worst)``: every unit of mass must travel to the worst child.
    """
    if budget <= BUDGET_ATOL or max(values) - min(values) <= 1e-12 * (1.0 + abs(values[0])):
        return list(w0)
    worst = min(range(len(values)), key=values.__getitem__)
    cost = math.fsum(p * _row(distances, i)[worst] for i, p in enumerate(w0))
    if cost <= budget:
        return [1.0 if i == worst else 0.0 for i in range(len(values))]
    lam = budget / cost
    return [(1.0 - lam) * p + (lam if i == worst else 0.0) for i, p in enumerate(w0)]


def wasserstein_lp(
    w0: Vector, values: Vector, distances: Matrix | None, budget: float
) -> list[float]:
    """The exact worst case: ``argmin_w w · v`` subject to ``W1(w0, w) <= budget``.

    **Reduction.** ``W1(w0, w) <= c`` holds iff some transport plan ``γ >= 0`` with row sums
    ``w0`` and column sums ``w`` costs ``Σ γ_ij d_ij <= c``. The column sums are free (``w`` is
    what we choose), so the problem is ``min Σ_ij γ_ij v_j`` over plans with row sums ``w0`` and
    cost ``<= c``. Writing ``γ_ij = w0_i x_ij`` with ``x_i`` a distribution over destinations,
    the objective is ``w0 · v - Σ_i w0_i g_i(x_i)`` with gain ``g_i(x_i) = Σ_j x_ij (v_i - v_j)``
    at per-unit cost ``Σ_j x_ij d_ij``.

    **Per source.** The best gain at per-unit cost ``b`` is ``f_i(b)``, the upper concave
    envelope of the points ``(d_ij, v_i - v_j)`` from ``(0, 0)`` (staying put): concave,
    non-decreasing, piecewise linear. Only the envelope's vertices are ever used.

    **Greedy is exact.** What remains, ``max Σ_i w0_i f_i(b_i)`` s.t. ``Σ_i w0_i b_i <= c``, is a
    separable concave maximisation under one linear constraint; in terms of the spent budgets
    ``y_i = w0_i b_i`` each term is concave piecewise linear with the slopes of ``f_i``. Taking
    envelope segments in order of decreasing slope (gain per unit of budget), the last one
    partly, is optimal: a fractional knapsack whose items may be taken in any order that
    respects each source's order, which decreasing slopes do since every envelope's slopes
    decrease. Free segments (cost 0, gain > 0, between children at distance 0) come first.
    Cost: ``O(n^3)`` for ``n`` children, no LP solver.
    """
    n = len(values)
    if budget < 0.0:
        raise ValueError(f"budget={budget!r} must be >= 0")
    segments = []  # (-slope, source, from_child, to_child, cost per unit of mass)
    for i, mass in enumerate(w0):
        if mass <= 0.0:
            continue
        row = _row(distances, i)
        at, cost_at, gain_at = i, 0.0, 0.0
        while True:
            best = None
            for j in range(n):
                gain = values[i] - values[j]
                if gain <= gain_at:
                    continue
                extra = row[j] - cost_at
                slope = math.inf if extra <= 0.0 else (gain - gain_at) / extra
                if best is None or (slope, gain) > (best[0], best[1]):
                    best = (slope, gain, j)
            if best is None:
                break
            slope, gain, j = best
            segments.append((-slope, i, at, j, max(row[j] - cost_at, 0.0)))
            at, cost_at, gain_at = j, max(row[j], cost_at), gain
    segments.sort(key=lambda segment: segment[0])  # stable: keeps each source's order
    w = list(w0)
    left = budget
    for _, i, start, end, unit_cost in segments:
        cost = w0[i] * unit_cost
        fraction = 1.0 if cost <= left else left / cost
        w[start] -= fraction * w0[i]
        w[end] += fraction * w0[i]
        left = max(left - fraction * cost, 0.0)
        if fraction < 1.0:
            break
    return [max(p, 0.0) for p in w]


def _row(distances: Matrix | None, i: int) -> Sequence[float]:
    if distances is None:
        raise ValueError("a Wasserstein worst case needs the children's distances (got None)")
    return distances[i]


WORST_CASES: dict[str, WorstCaseFn] = {
    "dirac_support": dirac_support,
    "wasserstein_direct": wasserstein_direct,
    "wasserstein_lp": wasserstein_lp,
}
"""The worst-case rules RATS accepts, by name."""
