"""NS-Gym's full schedule vocabulary, natively: formulas, validation, seeding, use in an env.

Expected values are written from each rule's documented formula (closed forms under a schedule
that fires at every step from 0), not pasted from a run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from ns_pz.envs.cartpole import CartPoleFamily
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz import NSGymEnv
from ns_pz.nature import (
    DISTRIBUTION_UPDATES,
    SCALAR_UPDATES,
    SCHEDULERS,
    BoundedRandomWalk,
    BudgetBoundedIncrement,
    BurstScheduler,
    ContinuousScheduler,
    CustomScheduler,
    CyclicUpdate,
    DecayingProbabilityScheduler,
    DecrementUpdate,
    DeterministicTrend,
    DiscreteScheduler,
    DistributionCyclicUpdate,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionLinearInterpolation,
    DistributionNoUpdate,
    DistributionStepWiseUpdate,
    ExponentialDecay,
    GeometricProgression,
    IncrementUpdate,
    LinearInterpolation,
    LipschitzBoundedDistributionUpdate,
    MemorylessScheduler,
    NoUpdate,
    OrnsteinUhlenbeck,
    OscillatingUpdate,
    PeriodicScheduler,
    PolynomialTrend,
    RandomCategorical,
    RandomScheduler,
    RandomWalk,
    RandomWalkWithDrift,
    RandomWalkWithDriftAndTrend,
    ScriptedNature,
    SigmoidTransition,
    StepWiseUpdate,
    TargetReversion,
    UniformDrift,
    WindowScheduler,
)
from ns_pz.nature.distribution_updates import total_variation

ALWAYS = ContinuousScheduler(start=0)


def fired(scheduler, steps=12, seed=0, only=None):
    """Steps at which ``scheduler`` fires, asking at ``only`` (default: 0..steps-1)."""
    rng = np.random.default_rng(seed)
    return [t for t in (range(steps) if only is None else only) if scheduler(t, rng)]


def path(rule, start, steps, seed=0):
    """Values after each of ``steps`` firings at t = 0, 1, ... (as ScriptedNature drives them)."""
    nature = ScriptedNature({"p": rule})
    memory = nature.initial_memory()
    rng = np.random.default_rng(seed)
    value, out = start, []
    for t in range(steps):
        if rule.scheduler(t, rng):
            n = memory["p"]
            memory["p"] = n + 1
            if rule.stateful:
                value = rule.update(value, t, n, rng, memory["memory", "p"])
            else:
                value = rule.update(value, t, n, rng)
        out.append(value)
    return out


# -- schedulers -------------------------------------------------------------------------------
def test_deterministic_schedulers_fire_where_documented():
    """Burst, window and custom schedulers fire on the documented steps."""
    assert fired(BurstScheduler(2, 3, start=0)) == [0, 1, 5, 6, 10, 11]
    assert fired(BurstScheduler(1, 2, start=4, end=9)) == [4, 7]
    assert fired(BurstScheduler(3, 0, start=2, end=5)) == [2, 3, 4, 5]
    assert fired(WindowScheduler([(2, 3), (7, 7)])) == [2, 3, 7]
    assert fired(CustomScheduler(lambda t, rng: t % 4 == 1)) == [1, 5, 9]
    assert fired(DiscreteScheduler(set())) == []


def test_memoryless_is_a_bernoulli_process_after_start():
    """p=1 fires at every step after start (never at start); p=0 never; draws follow the rng."""
    assert fired(MemorylessScheduler(1.0, start=3, end=8)) == [4, 5, 6, 7, 8]
    assert fired(MemorylessScheduler(0.0, start=0)) == []
    scheduler = MemorylessScheduler(0.3, start=0)
    assert fired(scheduler, 60, seed=5) == fired(scheduler, 60, seed=5)
    assert fired(scheduler, 60, seed=5) != fired(scheduler, 60, seed=6)
    # Each step after start: one uniform u, fire iff u < p.
    rng = np.random.default_rng(5)
    assert fired(scheduler, 60, seed=5) == [t for t in range(1, 60) if rng.random() < 0.3]


def test_memoryless_keeps_firing_when_steps_are_skipped():
    """Asked only on even steps, it keeps firing at about rate p (NS-Gym's stops for good)."""
    evens = range(0, 4000, 2)
    count = len(fired(MemorylessScheduler(0.3, start=0), only=evens, seed=1))
    assert 0.25 * len(evens) < count < 0.35 * len(evens)
    assert max(fired(MemorylessScheduler(0.3, start=0), only=evens, seed=1)) > 3900


def test_decaying_probability_follows_its_formula():
    """Fires iff u_t < p0 exp(-rate (t - start)), one u per step of the window."""
    scheduler = DecayingProbabilityScheduler(0.9, 0.1, start=2, end=40)
    assert scheduler.probability(2) == 0.9
    assert scheduler.probability(12) == pytest.approx(0.9 * math.exp(-1.0))
    rng = np.random.default_rng(8)
    expected = [t for t in range(2, 41) if rng.random() < 0.9 * math.exp(-0.1 * (t - 2))]
    assert fired(scheduler, 50, seed=8) == expected
    assert fired(DecayingProbabilityScheduler(1.0, 0.0, start=0), 5) == [0, 1, 2, 3, 4]


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: MemorylessScheduler(1.2, start=0), ValueError, r"p=1.2 must lie in \[0, 1\]"),
        (lambda: MemorylessScheduler(0.5, start=-1), ValueError, r"start=-1 must be >= 0"),
        (lambda: DecayingProbabilityScheduler(0.5, -1, start=0), ValueError, r"decay_rate=-1"),
        (lambda: DecayingProbabilityScheduler(2, 1, start=0), ValueError, r"initial_probability=2"),
        (lambda: BurstScheduler(0, 3, start=0), ValueError, r"on_duration=0 must be >= 1"),
        (lambda: BurstScheduler(1, -3, start=0), ValueError, r"off_duration=-3 must be >= 0"),
        (lambda: BurstScheduler(1.5, 3, start=0), TypeError, r"on_duration=1.5 must be an int"),
        (lambda: WindowScheduler([(5, 2)]), ValueError, r"windows\[0\]=\(5, 2\) ends before"),
        (lambda: WindowScheduler([(1, 2, 3)]), ValueError, r"windows\[0\]=\(1, 2, 3\) must have 2"),
        (lambda: WindowScheduler(4), TypeError, r"windows=4 must be an iterable"),
        (lambda: WindowScheduler([(-1, 2)]), ValueError, r"windows\[0\] first=-1 must be >= 0"),
        (lambda: CustomScheduler(3), TypeError, r"event_function=3 must be callable"),
        (lambda: CustomScheduler(lambda t: True), TypeError, r"must accept two arguments"),
    ],
)
def test_new_scheduler_arguments_are_checked(build, error, match):
    """Bad arguments raise naming the argument, the value and the rule."""
    with pytest.raises(error, match=match):
        build()


def test_custom_scheduler_refuses_a_non_bool_answer():
    """A function returning something other than a bool is reported with the step."""
    scheduler = CustomScheduler(lambda t, rng: "yes")
    with pytest.raises(TypeError, match=r"returned 'yes' at t=3; it must return a bool"):
        scheduler(3, np.random.default_rng(0))


# -- scalar rules -----------------------------------------------------------------------------
def test_accumulating_scalar_rules_follow_their_closed_forms():
    """Trend, polynomial, oscillation and decay add their t-term to the current value."""
    steps = range(12)
    assert path(DeterministicTrend(ALWAYS, slope=0.5), 1.0, 12) == pytest.approx(
        [1.0 + 0.5 * t * (t + 1) / 2 for t in steps]
    )
    a, b = 0.2, -0.03
    assert path(PolynomialTrend(ALWAYS, [a, b]), 2.0, 12) == pytest.approx(
        [2.0 + a * t * (t + 1) / 2 + b * t * (t + 1) * (2 * t + 1) / 6 for t in steps]
    )
    half = 0.5
    assert path(OscillatingUpdate(ALWAYS, delta=0.4), 9.8, 12) == pytest.approx(
        [9.8 + 0.4 * (math.cos(half) - math.cos(t + half)) / (2 * math.sin(half)) for t in steps]
    )
    assert path(ExponentialDecay(ALWAYS, decay_rate=0.1), 3.0, 12) == pytest.approx(
        [3.0 * math.exp(-0.1 * t * (t + 1) / 2) for t in steps]
    )


def test_replacing_and_multiplying_scalar_rules():
    """Geometric, sigmoid, interpolation, cyclic, step-wise and OU rules."""
    steps = range(12)
    assert path(GeometricProgression(ALWAYS, r=0.9), 2.0, 12) == pytest.approx(
        [2.0 * 0.9 ** (t + 1) for t in steps]
    )
    assert path(SigmoidTransition(ALWAYS, a=1.0, b=3.0, k=0.8, t0=5), 0.0, 12) == pytest.approx(
        [1.0 + 2.0 / (1.0 + math.exp(-0.8 * (t - 5))) for t in steps]
    )
    assert path(LinearInterpolation(ALWAYS, 1.0, 2.0, T=4), 0.0, 8) == pytest.approx(
        [1.0, 1.25, 1.5, 1.75, 2.0, 2.0, 2.0, 2.0]
    )
    assert path(CyclicUpdate(ALWAYS, [0.1, 0.2, 0.3]), 9.0, 7) == [
        0.1,
        0.2,
        0.3,
        0.1,
        0.2,
        0.3,
        0.1,
    ]
    assert path(StepWiseUpdate(PeriodicScheduler(2, start=1), [4.0, 5.0]), 1.0, 7) == [
        1.0,
        4.0,
        4.0,
        5.0,
        5.0,
        5.0,
        5.0,
    ]
    assert path(OrnsteinUhlenbeck(ALWAYS, theta=0.25, mu=2.0), 10.0, 12) == pytest.approx(
        [2.0 + 8.0 * 0.75 ** (t + 1) for t in steps]
    )
    assert path(IncrementUpdate(ALWAYS, k=0.5), 0.0, 3) == [0.5, 1.0, 1.5]
    assert path(DecrementUpdate(ALWAYS, k=0.5), 0.0, 3) == [-0.5, -1.0, -1.5]
    assert path(NoUpdate(ALWAYS), 7.0, 3) == [7.0, 7.0, 7.0]


def test_random_walks_draw_from_the_generator_they_are_given():
    """Same seed, same path; noise-free walks follow the drift and trend formulas."""
    for rule in (
        RandomWalk(ALWAYS, mu=0.1, sigma=0.5),
        RandomWalkWithDrift(ALWAYS, alpha=0.2, mu=0.0, sigma=1.0),
        RandomWalkWithDriftAndTrend(ALWAYS, alpha=0.2, mu=0.0, sigma=1.0, slope=0.01),
        OrnsteinUhlenbeck(ALWAYS, theta=0.5, mu=1.0, sigma=0.3),
        BoundedRandomWalk(ALWAYS, mu=0.0, sigma=2.0, lo=-1.0, hi=1.0),
    ):
        assert path(rule, 0.0, 20, seed=4) == path(rule, 0.0, 20, seed=4)
        assert path(rule, 0.0, 20, seed=4) != path(rule, 0.0, 20, seed=5)
    steps = range(10)
    drift = RandomWalkWithDrift(ALWAYS, alpha=0.2, mu=0.05, sigma=0.0)
    assert path(drift, 1.0, 10) == pytest.approx([1.0 + 0.25 * (t + 1) for t in steps])
    trend = RandomWalkWithDriftAndTrend(ALWAYS, alpha=0.2, mu=0.0, sigma=0.0, slope=0.1)
    assert path(trend, 0.0, 10) == pytest.approx(
        [0.2 * (t + 1) + 0.1 * t * (t + 1) / 2 for t in steps]
    )
    rng = np.random.default_rng(2)
    walk = path(RandomWalk(ALWAYS, mu=0.0, sigma=1.0), 0.0, 5, seed=2)
    assert walk == pytest.approx(np.cumsum(rng.standard_normal(5)).tolist())


def test_bounded_random_walk_stays_in_its_bounds():
    """Every value of a wide walk lies in [lo, hi], and both bounds are reached."""
    values = path(BoundedRandomWalk(ALWAYS, mu=0.0, sigma=3.0, lo=-1.0, hi=2.0), 0.0, 200, 3)
    assert min(values) == -1.0 and max(values) == 2.0


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: DeterministicTrend(ALWAYS, slope=math.inf), ValueError, r"slope=inf"),
        (lambda: ExponentialDecay(ALWAYS, decay_rate=-0.1), ValueError, r"decay_rate=-0.1"),
        (lambda: GeometricProgression(ALWAYS, r="x"), TypeError, r"r='x' must be a real"),
        (lambda: OrnsteinUhlenbeck(ALWAYS, 1.5, 0.0), ValueError, r"theta=1.5 must lie in"),
        (lambda: OrnsteinUhlenbeck(ALWAYS, 0.5, 0.0, -1), ValueError, r"sigma=-1"),
        (lambda: BoundedRandomWalk(ALWAYS, 0, 1, 2, 1), ValueError, r"hi=1 is below lo=2"),
        (lambda: LinearInterpolation(ALWAYS, 0, 1, T=0), ValueError, r"T=0 must be >= 1"),
        (lambda: LinearInterpolation(ALWAYS, 0, 1, T=2.5), TypeError, r"T=2.5 must be an int"),
        (lambda: CyclicUpdate(ALWAYS, []), ValueError, r"value_list=\[\] is empty"),
        (lambda: PolynomialTrend(ALWAYS, [1, math.nan]), ValueError, r"coeffs\[1\]=nan"),
        (lambda: SigmoidTransition(ALWAYS, 0, 1, None, 2), TypeError, r"k=None"),
        (lambda: RandomWalkWithDrift(ALWAYS, 0, 0, -2), ValueError, r"sigma=-2"),
        (lambda: StepWiseUpdate(ALWAYS, "abc"), TypeError, r"param_list='abc' must be a seq"),
    ],
)
def test_scalar_rule_arguments_are_checked(build, error, match):
    """Bad arguments raise naming the argument, the value and the rule."""
    with pytest.raises(error, match=match):
        build()


# -- distribution rules -----------------------------------------------------------------------
def is_distribution(vector):
    """Non-negative and summing to 1."""
    return min(vector) >= 0.0 and math.isclose(sum(vector), 1.0, abs_tol=1e-12)


def test_distribution_rules_follow_their_formulas():
    """Drift, reversion, interpolation and cyclic rules, from their closed forms."""
    p0 = np.array([1.0, 0.0, 0.0])
    uniform = np.full(3, 1 / 3)
    drift = path(UniformDrift(ALWAYS, rate=0.2), tuple(p0), 6)
    for t, vector in enumerate(drift):
        assert vector == pytest.approx(uniform + 0.8 ** (t + 1) * (p0 - uniform))
    target = np.array([0.2, 0.3, 0.5])
    revert = path(TargetReversion(ALWAYS, target=target.tolist(), theta=0.5), tuple(p0), 6)
    for t, vector in enumerate(revert):
        assert vector == pytest.approx(target + 0.5 ** (t + 1) * (p0 - target))
    line = path(
        DistributionLinearInterpolation(ALWAYS, [1, 0, 0], [0, 0.5, 0.5], T=4), (0, 0, 1), 6
    )
    for t, vector in enumerate(line):
        assert vector == pytest.approx(p0 + min(t / 4, 1) * (np.array([0, 0.5, 0.5]) - p0))
    cycle = [(0.5, 0.5, 0.0), (0.2, 0.2, 0.6)]
    assert path(DistributionCyclicUpdate(ALWAYS, cycle), (1.0, 0.0, 0.0), 3) == [*cycle, cycle[0]]
    assert path(DistributionNoUpdate(ALWAYS), (0.5, 0.5), 2) == [(0.5, 0.5)] * 2
    increments = path(DistributionIncrementUpdate(ALWAYS, k=0.3), (0.5, 0.5, 0.0), 2)
    assert np.array(increments) == pytest.approx(np.array([(0.8, 0.1, 0.1), (1.0, 0.0, 0.0)]))
    for rule in (DistributionStepWiseUpdate, DistributionCyclicUpdate):
        assert path(rule(ALWAYS, [(0.1, 0.9)]), (1.0, 0.0), 1) == [(0.1, 0.9)]
    assert all(is_distribution(v) for v in drift + revert + line)


def test_random_categorical_draws_valid_vectors_from_the_generator():
    """Dirichlet(1, ..., 1) draws: valid, reproducible by seed, spread over the simplex."""
    rule = RandomCategorical(ALWAYS)
    draws = path(rule, (0.25,) * 4, 300, seed=1)
    assert all(is_distribution(v) and len(v) == 4 for v in draws)
    assert draws == path(rule, (0.25,) * 4, 300, seed=1) != path(rule, (0.25,) * 4, 300, seed=2)
    assert np.mean(draws, axis=0) == pytest.approx([0.25] * 4, abs=0.03)


def test_lipschitz_bounded_update_moves_at_most_l_per_firing():
    """A far proposal is shortened to exactly L along the line towards it; near ones pass."""
    bounded = LipschitzBoundedDistributionUpdate(
        ALWAYS, L=0.05, update_fn=UniformDrift(ALWAYS, 1.0)
    )
    first = bounded.update((1.0, 0.0, 0.0), 0, 0, np.random.default_rng(0))
    assert first == pytest.approx((0.95, 0.025, 0.025))
    assert total_variation((1.0, 0.0, 0.0), first) == pytest.approx(0.05)
    near = LipschitzBoundedDistributionUpdate(ALWAYS, 0.5, DistributionIncrementUpdate(ALWAYS, 0.1))
    assert near.update((0.5, 0.5), 0, 0, np.random.default_rng(0)) == pytest.approx((0.6, 0.4))
    walk = path(LipschitzBoundedDistributionUpdate(ALWAYS, L=0.02), (1 / 3,) * 3, 200, seed=3)
    previous = (1 / 3,) * 3
    for vector in walk:
        assert is_distribution(vector)
        assert total_variation(previous, vector) <= 0.02 + 1e-12
        previous = vector
    assert walk == path(LipschitzBoundedDistributionUpdate(ALWAYS, L=0.02), (1 / 3,) * 3, 200, 3)


def test_budget_bounded_increment_stops_when_the_budget_is_spent():
    """Each decrement of 0.1 costs 0.1; the third is cut to what is left; then nothing moves."""
    rule = BudgetBoundedIncrement(ALWAYS, k=-0.1, B=0.25)
    values = path(rule, (1.0, 0.0, 0.0), 5)
    expected = [(0.9, 0.05, 0.05), (0.8, 0.1, 0.1)] + [(0.75, 0.125, 0.125)] * 3
    assert np.array(values) == pytest.approx(np.array(expected))


def test_budget_is_per_episode_inside_an_environment():
    """Every episode gets the whole budget again (the memory lives in nature's episode memory)."""
    rule = BudgetBoundedIncrement(ALWAYS, k=-0.2, B=0.3)
    env = NSGymEnv(
        FrozenLakeFamily(),
        params=FrozenLakeParams(slip=(1.0, 0.0, 0.0)),
        nature=ScriptedNature({"slip": rule}),
        max_episode_steps=None,
    )
    for seed in (0, 1):
        env.reset(seed=seed)
        for _ in range(3):
            env.step(1)  # DOWN: the 4x4 lake's first column is safe for three steps
        truth = env.ground_truth()
        assert truth.theta.slip == pytest.approx((0.7, 0.15, 0.15))
        assert truth.total_change == pytest.approx(0.3)


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: UniformDrift(ALWAYS, rate=1.5), ValueError, r"rate=1.5 must lie in \[0.0, 1.0\]"),
        (
            lambda: TargetReversion(ALWAYS, [2.0, 0.0, 0.0], 0.5),
            ValueError,
            r"target=\[2.0, 0.0, 0.0\] sums to 2.0",
        ),
        (lambda: TargetReversion(ALWAYS, [0.5, 0.5], -0.1), ValueError, r"theta=-0.1 must lie"),
        (
            lambda: DistributionLinearInterpolation(ALWAYS, [1, 0], [0, 0.5, 0.5], 3),
            ValueError,
            r"end_dist=\[0, 0.5, 0.5\] has 3 elements but start_dist has 2",
        ),
        (
            lambda: DistributionCyclicUpdate(ALWAYS, [[0.5, 0.5], [0.2, 0.2, 0.5]]),
            ValueError,
            r"dist_list\[1\]=\[0.2, 0.2, 0.5\] sums to 0.9",
        ),
        (lambda: DistributionCyclicUpdate(ALWAYS, []), ValueError, r"dist_list=\[\] is empty"),
        (lambda: DistributionStepWiseUpdate(ALWAYS, [[-0.5, 1.5]]), ValueError, r"negative"),
        (lambda: LipschitzBoundedDistributionUpdate(ALWAYS, L=-1), ValueError, r"L=-1"),
        (
            lambda: LipschitzBoundedDistributionUpdate(ALWAYS, 0.1, IncrementUpdate(ALWAYS, 1)),
            TypeError,
            r"update_fn=IncrementUpdate\(.*\) must be an ns_pz distribution update",
        ),
        (lambda: BudgetBoundedIncrement(ALWAYS, k=0.1, B=-1), ValueError, r"B=-1"),
        (lambda: BudgetBoundedIncrement(ALWAYS, k=math.nan, B=1), ValueError, r"k=nan"),
    ],
)
def test_distribution_rule_arguments_are_checked(build, error, match):
    """A bad vector or coefficient is refused when the rule is built (NS-Gym accepts them)."""
    with pytest.raises(error, match=match):
        build()


def test_vector_lengths_are_checked_against_the_parameter():
    """A target or interpolation end point of the wrong length is refused at bind time."""
    for rule in (
        TargetReversion(ALWAYS, [0.5, 0.5], 0.5),
        DistributionLinearInterpolation(ALWAYS, [1, 0], [0, 1], 3),
        DistributionCyclicUpdate(ALWAYS, [[1, 0]]),
        LipschitzBoundedDistributionUpdate(ALWAYS, 0.1, DistributionCyclicUpdate(ALWAYS, [[1, 0]])),
    ):
        with pytest.raises(ValueError, match="has 2 elements but parameter 'slip' has 3"):
            ScriptedNature({"slip": rule}).bind(FrozenLakeParams)
    with pytest.raises(ValueError, match="needs a vector of >= 2 outcomes"):
        BudgetBoundedIncrement(ALWAYS, 0.1, 1.0).check_size("p", 1)


# -- every rule, in an environment --------------------------------------------------------------
SCHEDULER_FACTORIES = {
    BurstScheduler: lambda: BurstScheduler(2, 1, start=1),
    ContinuousScheduler: lambda: ContinuousScheduler(start=1),
    CustomScheduler: lambda: CustomScheduler(lambda t, rng: rng.random() < 0.5),
    DecayingProbabilityScheduler: lambda: DecayingProbabilityScheduler(0.9, 0.05, start=0),
    DiscreteScheduler: lambda: DiscreteScheduler({1, 4, 9}),
    MemorylessScheduler: lambda: MemorylessScheduler(0.4, start=0),
    PeriodicScheduler: lambda: PeriodicScheduler(3, start=1),
    RandomScheduler: lambda: RandomScheduler(0.5, start=0),
    WindowScheduler: lambda: WindowScheduler([(1, 3), (8, 12)]),
}
SCALAR_FACTORIES = {
    BoundedRandomWalk: lambda s: BoundedRandomWalk(s, 0.0, 0.05, 0.05, 0.5),
    CyclicUpdate: lambda s: CyclicUpdate(s, [0.2, 0.3]),
    DecrementUpdate: lambda s: DecrementUpdate(s, 0.01),
    DeterministicTrend: lambda s: DeterministicTrend(s, 0.001),
    ExponentialDecay: lambda s: ExponentialDecay(s, 0.01),
    GeometricProgression: lambda s: GeometricProgression(s, 1.05),
    IncrementUpdate: lambda s: IncrementUpdate(s, 0.05),
    LinearInterpolation: lambda s: LinearInterpolation(s, 0.1, 0.6, 10),
    NoUpdate: NoUpdate,
    OrnsteinUhlenbeck: lambda s: OrnsteinUhlenbeck(s, 0.3, 0.4, 0.05),
    OscillatingUpdate: lambda s: OscillatingUpdate(s, 0.05),
    PolynomialTrend: lambda s: PolynomialTrend(s, [0.001, 0.0001]),
    RandomWalk: lambda s: RandomWalk(s, 0.0, 0.05),
    RandomWalkWithDrift: lambda s: RandomWalkWithDrift(s, 0.01, 0.0, 0.05),
    RandomWalkWithDriftAndTrend: lambda s: RandomWalkWithDriftAndTrend(s, 0.01, 0.0, 0.05, 0.001),
    SigmoidTransition: lambda s: SigmoidTransition(s, 0.1, 0.9, 0.5, 6),
    StepWiseUpdate: lambda s: StepWiseUpdate(s, [0.3, 0.6]),
}
DISTRIBUTION_FACTORIES = {
    BudgetBoundedIncrement: lambda s: BudgetBoundedIncrement(s, -0.1, 0.3),
    DistributionCyclicUpdate: lambda s: DistributionCyclicUpdate(s, [[0.8, 0.1, 0.1], [1, 0, 0]]),
    DistributionDecrementUpdate: lambda s: DistributionDecrementUpdate(s, 0.1),
    DistributionIncrementUpdate: lambda s: DistributionIncrementUpdate(s, 0.1),
    DistributionLinearInterpolation: lambda s: DistributionLinearInterpolation(
        s, [1, 0, 0], [0.4, 0.3, 0.3], 10
    ),
    DistributionNoUpdate: DistributionNoUpdate,
    DistributionStepWiseUpdate: lambda s: DistributionStepWiseUpdate(s, [[0.5, 0.25, 0.25]]),
    LipschitzBoundedDistributionUpdate: lambda s: LipschitzBoundedDistributionUpdate(s, 0.1),
    RandomCategorical: RandomCategorical,
    TargetReversion: lambda s: TargetReversion(s, [0.6, 0.2, 0.2], 0.5),
    UniformDrift: lambda s: UniformDrift(s, 0.2),
}


def test_every_class_of_the_vocabulary_is_exercised_here():
    """The factories below cover every exported scheduler and update function."""
    assert set(SCHEDULER_FACTORIES) == set(SCHEDULERS)
    assert set(SCALAR_FACTORIES) == set(SCALAR_UPDATES)
    assert set(DISTRIBUTION_FACTORIES) == set(DISTRIBUTION_UPDATES)
    assert len(SCHEDULERS) == 9 and len(SCALAR_UPDATES) == 17 and len(DISTRIBUTION_UPDATES) == 11


def trajectory(env, seed, steps=25):
    """θ after every step of one episode (restarting the episode if it ends)."""
    env.reset(seed=seed)
    out = []
    actions = np.random.default_rng(seed)
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(int(actions.integers(2)))
        out.append(env.ground_truth().theta)
        if terminated or truncated:
            env.reset()
    return out


@pytest.mark.parametrize("scheduler", list(SCHEDULER_FACTORIES), ids=lambda c: c.__name__)
@pytest.mark.parametrize("rule", list(SCALAR_FACTORIES), ids=lambda c: c.__name__)
def test_every_scalar_rule_runs_reproducibly_in_cartpole(rule, scheduler):
    """Valid θ at every step; the same seed gives the same θ trajectory."""
    nature = ScriptedNature({"masspole": SCALAR_FACTORIES[rule](SCHEDULER_FACTORIES[scheduler]())})
    env = NSGymEnv(CartPoleFamily(), nature=nature, max_episode_steps=None)
    first = trajectory(env, 11)
    assert first == trajectory(env, 11)
    for theta in first:
        assert type(theta)(**theta.as_dict()) == theta  # validates


@pytest.mark.parametrize("scheduler", list(SCHEDULER_FACTORIES), ids=lambda c: c.__name__)
@pytest.mark.parametrize("rule", list(DISTRIBUTION_FACTORIES), ids=lambda c: c.__name__)
def test_every_distribution_rule_runs_reproducibly_in_frozen_lake(rule, scheduler):
    """Every proposal is already a probability vector; the same seed, the same trajectory."""
    built = DISTRIBUTION_FACTORIES[rule](SCHEDULER_FACTORIES[scheduler]())
    env = NSGymEnv(
        FrozenLakeFamily(),
        params=FrozenLakeParams(slip=(0.8, 0.1, 0.1)),
        nature=ScriptedNature({"slip": built}),
        max_episode_steps=None,
    )
    first = trajectory(env, 7)
    assert first == trajectory(env, 7)
    assert all(is_distribution(theta.slip) for theta in first)


def test_random_rules_and_schedulers_follow_the_reset_seed():
    """Different seeds give different trajectories for a random schedule of a random rule."""
    nature = ScriptedNature(
        {"masspole": RandomWalk(MemorylessScheduler(0.5, start=0), mu=0.0, sigma=0.02)}
    )
    env = NSGymEnv(CartPoleFamily(), nature=nature, max_episode_steps=None)
    assert trajectory(env, 1) != trajectory(env, 2)
