"""Nature's worst case at a RATS chance node, checked against exact LPs solved by brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from ns_pz.agents.search.worst_case import dirac_support, wasserstein_direct, wasserstein_lp


def lp_min_by_vertices(cost: np.ndarray, a_eq: np.ndarray, b_eq: np.ndarray) -> float:
    """Minimum of cost·x s.t. a_eq x = b_eq, x >= 0, by trying every basis (tiny problems only)."""
    rows, cols = a_eq.shape
    best = np.inf
    for basis in itertools.combinations(range(cols), rows):
        sub = a_eq[:, basis]
        if abs(np.linalg.det(sub)) < 1e-12:
            continue
        x_b = np.linalg.solve(sub, b_eq)
        if (x_b >= -1e-12).all():
            best = min(best, float(cost[list(basis)] @ x_b))
    return best


def ball_minimum(w0, values, distances, budget) -> float:
    """min_w w·v over W1(w0, w) <= budget, as an LP over transport plans plus one slack."""
    n = len(w0)
    a_eq = np.zeros((n + 1, n * n + 1))
    for i in range(n):
        a_eq[i, i * n : (i + 1) * n] = 1.0  # row sums = w0
    a_eq[n, : n * n] = np.asarray(distances).ravel()  # transport cost + slack = budget
    a_eq[n, n * n] = 1.0
    cost = np.concatenate([np.tile(values, n), [0.0]])
    return lp_min_by_vertices(cost, a_eq, np.concatenate([w0, [budget]]))


def wasserstein(w0, w, distances) -> float:
    """W1(w0, w) as a transport LP solved by vertex enumeration."""
    n = len(w0)
    a_eq = np.zeros((2 * n, n * n))
    for i in range(n):
        a_eq[i, i * n : (i + 1) * n] = 1.0
        a_eq[n + i, i::n] = 1.0
    a_eq, b_eq = a_eq[:-1], np.concatenate([w0, w])[:-1]  # one constraint is redundant
    return lp_min_by_vertices(np.asarray(distances).ravel(), a_eq, b_eq)


def random_instance(rng, n):
    """Children on a 3x3 grid (Manhattan metric, repeats allowed), sparse w0, tied values."""
    cells = rng.integers(3, size=(n, 2))
    distances = np.abs(cells[:, None, :] - cells[None, :, :]).sum(axis=2).astype(float)
    w0 = rng.dirichlet(np.ones(n))
    w0[rng.random(n) < 0.25] = 0.0
    if w0.sum() == 0.0:
        w0[0] = 1.0
    w0 /= w0.sum()
    values = rng.integers(-3, 4, size=n).astype(float) + rng.choice([0.0, 0.5], size=n)
    return w0, values, distances


@pytest.mark.parametrize("n", [2, 3, 4])
def test_lp_worst_case_is_the_exact_minimum_over_the_ball(n):
    """Against vertex enumeration of the transport LP, for budgets from 0 to more than enough."""
    rng = np.random.default_rng(n)
    for _ in range(12 if n < 4 else 3):
        w0, values, distances = random_instance(rng, n)
        for budget in (0.0, 0.1, 0.35, 0.8, 1.7, 10.0):
            w = wasserstein_lp(w0, values, distances.tolist(), budget)
            assert min(w) >= 0.0 and sum(w) == pytest.approx(1.0)
            assert np.dot(w, values) == pytest.approx(
                ball_minimum(w0, values, distances, budget), abs=1e-9
            )
            if n <= 3:
                assert wasserstein(w0, w, distances) <= budget + 1e-9


def test_lp_worst_case_on_a_fine_grid_of_a_line():
    """Three children at positions 0, 1, 3 of a line, where W1 is the area between CDFs."""
    positions = np.array([0.0, 1.0, 3.0])
    distances = np.abs(positions[:, None] - positions[None, :])
    w0, values = np.array([0.2, 0.5, 0.3]), np.array([1.0, -2.0, 0.5])
    gaps = np.diff(positions)
    a, b = np.meshgrid(np.linspace(0.0, 1.0, 401), np.linspace(0.0, 1.0, 401))
    inside = a + b <= 1.0 + 1e-12
    w = np.stack([a[inside], b[inside], np.clip(1.0 - a[inside] - b[inside], 0.0, None)], axis=1)
    cdf_gap = np.abs(np.cumsum(w, axis=1)[:, :-1] - np.cumsum(w0)[:-1])
    w1 = cdf_gap @ gaps
    for budget in (0.05, 0.3, 0.6):
        best = np.min((w @ values)[w1 <= budget + 1e-12])
        exact = np.dot(wasserstein_lp(w0, values, distances.tolist(), budget), values)
        assert exact <= best + 1e-12 and best - exact < 0.01


def test_direct_method_is_feasible_and_exact_when_the_dirac_is_affordable():
    """w0 at budget 0 or equal values; the Dirac when W1(w0, δ) <= c; else the mixture."""
    distances = [[0.0, 1.0, 2.0], [1.0, 0.0, 1.0], [2.0, 1.0, 0.0]]
    w0, values = [0.5, 0.3, 0.2], [1.0, 0.0, 2.0]
    assert wasserstein_direct(w0, values, distances, 0.0) == w0
    assert wasserstein_direct(w0, [1.0, 1.0, 1.0], distances, 5.0) == w0
    assert wasserstein_direct(w0, values, distances, 0.7) == [0.0, 1.0, 0.0]  # W1(w0, δ_1) = 0.7
    mixture = wasserstein_direct(w0, values, distances, 0.35)  # λ = 0.5
    np.testing.assert_allclose(mixture, [0.25, 0.65, 0.1])
    assert wasserstein(np.array(w0), np.array(mixture), distances) <= 0.35 + 1e-12
    lp = np.dot(wasserstein_lp(w0, values, distances, 0.35), values)
    assert np.dot(mixture, values) == pytest.approx(0.45)
    assert lp == pytest.approx(0.35)  # mass 0.2 from value 2 and 0.15 from value 1 to value 0


def test_direct_method_can_be_strictly_worse_than_the_lp():
    """A near child of low value beats moving everything to a far Dirac: the LP finds it."""
    distances = [[0.0, 1.0, 5.0], [1.0, 0.0, 4.0], [5.0, 4.0, 0.0]]
    w0, values, budget = [1.0, 0.0, 0.0], [1.0, 0.1, 0.0], 1.0
    direct = np.dot(wasserstein_direct(w0, values, distances, budget), values)
    exact = np.dot(wasserstein_lp(w0, values, distances, budget), values)
    assert direct == pytest.approx(0.8)  # λ = 1/5 of the way to the far child
    assert exact == pytest.approx(0.1)  # all mass to the near child, cost 1
    assert exact == pytest.approx(ball_minimum(np.array(w0), np.array(values), distances, budget))


def test_dirac_support_ignores_probabilities_and_budget():
    """Even an outcome of probability 0 can be nature's pick, at any budget."""
    assert dirac_support([1.0, 0.0, 0.0], [0.5, -1.0, 0.0], None, 0.0) == [0.0, 1.0, 0.0]
    assert dirac_support([0.2, 0.4, 0.4], [0.0, 0.0, 1.0], None, 0.0) == [1.0, 0.0, 0.0]


def test_wasserstein_rules_need_distances():
    """A Wasserstein rule without a metric is refused with a message."""
    with pytest.raises(ValueError, match="needs the children's distances"):
        wasserstein_lp([0.5, 0.5], [0.0, 1.0], None, 1.0)
    with pytest.raises(ValueError, match="budget=-1.0 must be >= 0"):
        wasserstein_lp([0.5, 0.5], [0.0, 1.0], [[0.0, 1.0], [1.0, 0.0]], -1.0)
