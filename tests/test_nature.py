"""Schedulers, update functions, scripted nature and the constraints the game enforces."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium import spaces
from ns_pz.envs.cartpole import CartPoleParams
from ns_pz.envs.frozen_lake import FrozenLakeParams

from ns_pz import ParamOutOfRange, UnknownParam
from ns_pz.nature import (
    ContinuousScheduler,
    DecrementUpdate,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionStepWiseUpdate,
    IncrementUpdate,
    NatureConstraints,
    PeriodicScheduler,
    RandomNature,
    RandomScheduler,
    RandomWalk,
    ScriptedNature,
    StepWiseUpdate,
)
from ns_pz.nature.constraints import admit

RNG = np.random.default_rng(0)


def fired(scheduler, steps=12, rng=None):
    """Steps (0..steps-1) at which ``scheduler`` fires."""
    rng = rng or np.random.default_rng(0)
    return [t for t in range(steps) if scheduler(t, rng)]


def test_schedulers_fire_at_the_documented_steps():
    """Continuous, discrete and periodic schedulers fire exactly where documented."""
    assert fired(ContinuousScheduler(start=1, end=3)) == [1, 2, 3]
    assert fired(ContinuousScheduler(start=10)) == [10, 11]
    assert fired(DiscreteScheduler({1, 5})) == [1, 5]
    assert fired(PeriodicScheduler(period=3, start=2)) == [2, 5, 8, 11]
    assert fired(PeriodicScheduler(period=2, start=0, end=4)) == [0, 2, 4]


def test_random_scheduler_is_driven_by_the_generator_it_is_given():
    """Same generator seed, same firing pattern; probability 0 and 1 are exact."""
    scheduler = RandomScheduler(probability=0.5, start=0)
    first = fired(scheduler, 50, np.random.default_rng(3))
    assert first == fired(scheduler, 50, np.random.default_rng(3))
    assert first != fired(scheduler, 50, np.random.default_rng(4))
    assert fired(RandomScheduler(0.0, start=0)) == []
    assert fired(RandomScheduler(1.0, start=0)) == list(range(12))


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: ContinuousScheduler(start=-1), ValueError, r"start=-1 must be >= 0"),
        (lambda: ContinuousScheduler(start=1.5), TypeError, r"start=1.5 must be an int"),
        (lambda: ContinuousScheduler(start=5, end=2), ValueError, r"end=2 is before start=5"),
        (lambda: PeriodicScheduler(period=0, start=0), ValueError, r"period=0 must be >= 1"),
        (lambda: RandomScheduler(probability=1.5, start=0), ValueError, r"probability=1.5"),
        (lambda: DiscreteScheduler(3), TypeError, r"event_list=3 must be an iterable"),
        (lambda: DiscreteScheduler({-2}), ValueError, r"event_list element=-2"),
    ],
)
def test_scheduler_arguments_are_checked(build, error, match):
    """Bad scheduler arguments raise with the argument, the value and the rule."""
    with pytest.raises(error, match=match):
        build()


def test_scalar_updates():
    """Increment, decrement, step-wise and random-walk rules compute the documented values."""
    always = ContinuousScheduler(start=0)
    assert IncrementUpdate(always, k=0.1).update(1.0, 0, 0, RNG) == 1.1
    assert DecrementUpdate(always, k=0.25).update(1.0, 0, 0, RNG) == 0.75
    stepwise = StepWiseUpdate(always, [1.0, 1.5])
    assert [stepwise.update(0.1, t, n, RNG) for t, n in [(0, 0), (1, 1), (2, 2)]] == [1.0, 1.5, 0.1]
    walk = RandomWalk(always, mu=0.0, sigma=0.0)
    assert walk.update(2.0, 0, 0, RNG) == 2.0
    rngs = np.random.default_rng(9), np.random.default_rng(9)
    walk = RandomWalk(always, sigma=1.0)
    assert walk.update(0.0, 0, 0, rngs[0]) == walk.update(0.0, 0, 0, rngs[1]) != 0.0


def test_distribution_updates_split_the_rest_equally_and_clip():
    """Distribution rules move the intended mass by k, clip at [0, 1] and share the rest equally."""
    always = ContinuousScheduler(start=0)
    down = DistributionDecrementUpdate(always, k=0.2)
    assert down.update((1.0, 0.0, 0.0), 0, 0, RNG) == pytest.approx((0.8, 0.1, 0.1))
    assert down.update((0.1, 0.5, 0.4), 0, 0, RNG) == (0.0, 0.5, 0.5)
    up = DistributionIncrementUpdate(always, k=0.3)
    assert up.update((0.9, 0.1, 0.0), 0, 0, RNG) == (1.0, 0.0, 0.0)
    stepwise = DistributionStepWiseUpdate(always, [(0.4, 0.3, 0.3)])
    assert stepwise.update((1.0, 0.0, 0.0), 0, 0, RNG) == (0.4, 0.3, 0.3)
    assert stepwise.update((1.0, 0.0, 0.0), 1, 1, RNG) == (1.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: IncrementUpdate("soon", k=1.0), TypeError, r"scheduler='soon' must be an ns_pz"),
        (lambda: IncrementUpdate(DiscreteScheduler({1}), k=math.nan), ValueError, r"k=nan"),
        (lambda: StepWiseUpdate(DiscreteScheduler({1}), []), ValueError, r"empty"),
        (lambda: RandomWalk(DiscreteScheduler({1}), sigma=-1), ValueError, r"sigma=-1"),
        (
            lambda: DistributionStepWiseUpdate(DiscreteScheduler({1}), [(0.5, 0.2, 0.2)]),
            ValueError,
            r"update_values\[0\]=\(0.5, 0.2, 0.2\) sums to 0.9",
        ),
    ],
)
def test_update_arguments_are_checked(build, error, match):
    """Bad update-function arguments raise with the value and the rule."""
    with pytest.raises(error, match=match):
        build()


def test_scripted_nature_binds_to_its_parameter_set():
    """Unknown names and rules of the wrong kind are refused when the env is built."""
    rule = IncrementUpdate(ContinuousScheduler(start=0), k=0.1)
    with pytest.raises(UnknownParam, match="'maspole'"):
        ScriptedNature({"maspole": rule}).bind(CartPoleParams)
    with pytest.raises(TypeError, match="is a probability vector"):
        ScriptedNature({"slip": rule}).bind(FrozenLakeParams)
    vector_rule = DistributionDecrementUpdate(ContinuousScheduler(start=0), k=0.1)
    with pytest.raises(TypeError, match="is a scalar"):
        ScriptedNature({"masspole": vector_rule}).bind(CartPoleParams)
    wrong_length = DistributionStepWiseUpdate(DiscreteScheduler({0}), [(0.5, 0.5)])
    with pytest.raises(ValueError, match="has 2 elements but parameter 'slip' has 3"):
        ScriptedNature({"slip": wrong_length}).bind(FrozenLakeParams)
    with pytest.raises(TypeError, match="must be an ns_pz update function"):
        ScriptedNature({"masspole": 0.3})


def test_scripted_nature_counts_firings_per_episode_in_its_memory():
    """The n-th firing gets n; a fresh memory starts the list again (one policy, many envs)."""
    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({1, 3}), [0.5, 0.7])})
    theta = CartPoleParams()
    memory = nature.initial_memory()
    proposals = [nature.propose(t, theta, math.inf, memory, RNG) for t in range(5)]
    assert proposals == [None, {"masspole": 0.5}, None, {"masspole": 0.7}, None]
    assert nature.propose(1, theta, math.inf, nature.initial_memory(), RNG) == {"masspole": 0.5}


def test_admit_projects_out_of_bounds_proposals():
    """A proposal outside the bounds is granted at the nearest allowed value."""
    theta, _ = admit(CartPoleParams(), {"masspole": -3.0}, NatureConstraints(), math.inf)
    assert theta.masspole == 1e-3
    theta, _ = admit(FrozenLakeParams(), {"slip": (0.9, 0.3, 0.0)}, NatureConstraints(), math.inf)
    assert sum(theta.slip) == pytest.approx(1.0) and min(theta.slip) >= 0
    unchanged = CartPoleParams()
    assert admit(unchanged, {"masspole": 0.1}, NatureConstraints(), math.inf)[0] is unchanged


def test_admit_enforces_lipschitz_and_budget():
    """Changes are shortened to the per-step bound, then all of them to the budget left."""
    bound = NatureConstraints(lipschitz=0.05)
    theta, sizes = admit(CartPoleParams(), {"masspole": 0.5}, bound, {})
    assert theta.masspole == pytest.approx(0.15) and sizes == {"masspole": pytest.approx(0.05)}
    lake, sizes = admit(FrozenLakeParams(slip=(1, 0, 0)), {"slip": (0, 1, 0)}, bound, {})
    assert lake.slip == pytest.approx((0.95, 0.05, 0.0))
    budget = NatureConstraints(budget=1.0)
    theta, sizes = admit(CartPoleParams(), {"masspole": 1.1, "gravity": 10.8}, budget, {})
    assert sum(sizes.values()) == pytest.approx(1.0)
    assert theta.masspole == pytest.approx(0.6) and theta.gravity == pytest.approx(10.3)
    spent, sizes = admit(CartPoleParams(), {"masspole": 0.5}, budget, {"gravity": 1.0})
    assert spent == CartPoleParams() and sizes == {}


def test_admit_enforces_per_parameter_and_normalized_budgets():
    """Per-parameter budgets are in each parameter's unit; the normalised one is shared."""
    own = NatureConstraints(budget={"masspole": 0.3, "tau": 0.01})
    theta, sizes = admit(CartPoleParams(), {"masspole": 1.1, "tau": 0.1}, own, {"tau": 0.005})
    assert theta.masspole == pytest.approx(0.4) and theta.tau == pytest.approx(0.025)
    assert sizes == {"masspole": pytest.approx(0.3), "tau": pytest.approx(0.005)}
    theta, _ = admit(CartPoleParams(), {"gravity": 20.0}, own, {})
    assert theta.gravity == 20.0  # not budgeted
    # Ranges: masspole (0, 1000] and tau [1e-4, 1]: a normalised budget of 0.001 allows 1 kg of
    # mass or 0.001 s of time step, and the two changes are shortened by one common factor.
    normal = NatureConstraints(normalized_budget=0.001)
    width_m, width_tau = CartPoleParams.spec("masspole").width, CartPoleParams.spec("tau").width
    theta, sizes = admit(CartPoleParams(), {"masspole": 1.1, "tau": 0.021}, normal, {})
    used = sizes["masspole"] / width_m + sizes["tau"] / width_tau
    assert used == pytest.approx(0.001)
    assert sizes["masspole"] / sizes["tau"] == pytest.approx(1.0 / 0.001)


def test_normalized_budget_needs_bounded_parameters():
    """A parameter without finite bounds has no width to normalise by."""
    from dataclasses import dataclass

    from ns_pz.params import Params, scalar

    @dataclass(frozen=True)
    class Free(Params):
        x: float = scalar(0.0)

    with pytest.raises(ValueError, match="normalized_budget=0.5 needs bounded parameters"):
        NatureConstraints(normalized_budget=0.5).check_names(Free)


def test_admit_refuses_nan_and_unknown_names():
    """NaN has no nearest allowed value; an unknown name is refused."""
    with pytest.raises(ParamOutOfRange, match="masspole=nan is NaN"):
        admit(CartPoleParams(), {"masspole": math.nan}, NatureConstraints(), {})
    with pytest.raises(UnknownParam):
        admit(CartPoleParams(), {"wind": 1.0}, NatureConstraints(), {})


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"lipschitz": -1.0}, ValueError, r"lipschitz=-1.0 must be >= 0"),
        ({"budget": math.nan}, ValueError, r"budget=nan must be finite"),
        ({"lipschitz": "x"}, TypeError, r"lipschitz='x' must be a real number"),
        ({"lipschitz": {"masspole": -2}}, ValueError, r"lipschitz\['masspole'\]=-2"),
    ],
)
def test_constraint_arguments_are_checked(kwargs, error, match):
    """Bad constraints raise with the value and the rule."""
    with pytest.raises(error, match=match):
        NatureConstraints(**kwargs)


def test_random_nature_stays_inside_bounds_after_projection():
    """RandomNature's proposals, once admitted, are always valid parameter sets."""
    nature = RandomNature(scale=1.0)
    rng = np.random.default_rng(2)
    for params in (CartPoleParams(), FrozenLakeParams()):
        theta = params
        for t in range(200):
            theta, _ = admit(
                theta, nature.propose(t, theta, math.inf, None, rng), NatureConstraints(), math.inf
            )
            assert type(theta)(**theta.as_dict()) == theta


def test_random_nature_scale_is_checked():
    """RandomNature needs a finite, non-negative real scale."""
    with pytest.raises(ValueError, match="scale=inf must be finite"):
        RandomNature(math.inf)
    with pytest.raises(ValueError, match="scale=-1 must be >= 0"):
        RandomNature(-1)
    with pytest.raises(TypeError, match="scale='big' must be a real number"):
        RandomNature("big")


@pytest.mark.parametrize(
    ("constraints", "moves"),
    [
        (NatureConstraints(budget=0.8), 8),
        (NatureConstraints(budget={"masspole": 0.8}), 8),
        (NatureConstraints(lipschitz=0.1, budget={"masspole": 0.8}), 8),
        (NatureConstraints(normalized_budget=0.3 / CartPoleParams.spec("masspole").width), 3),
    ],
    ids=["total", "per-parameter", "per-parameter+lipschitz", "normalized"],
)
def test_a_budget_spent_exactly_allows_no_rounding_sized_move(constraints, moves):
    """Steps that sum to the budget exhaust it, with no ulp-sized move after them.

    In floats, eight steps of 0.1 leave 1.1e-16 of a budget of 0.8, and three steps of 0.1
    leave 2e-16 of a normalised 0.3: a move that size would be notified as a change by an
    oracle monitor. The fraction left must read exactly 0.
    """
    from ns_pz.nature.constraints import budget_fractions_left

    theta, spent, changes = CartPoleParams(), {}, 0
    for _ in range(moves + 4):
        new, sizes = admit(theta, {"masspole": theta.masspole + 0.1}, constraints, spent)
        for name, size in (sizes or {}).items():
            spent[name] = spent.get(name, 0.0) + size
        changes += new is not theta
        theta = new
    assert changes == moves
    assert theta.masspole == pytest.approx(0.1 + 0.1 * moves, abs=1e-12)
    assert min(budget_fractions_left(constraints, CartPoleParams, spent)) == 0.0


def test_action_of_refuses_proposals_that_do_not_fit_theta():
    """A name θ does not have, or a probability vector of the wrong length, is refused."""
    from ns_pz.envs.frozen_lake import FrozenLakeFamily

    from ns_pz.nature.interface import NatureInterface

    family = FrozenLakeFamily()
    interface = NatureInterface(family, FrozenLakeParams(), NatureConstraints(), 100)
    with pytest.raises(UnknownParam, match="nope"):
        interface.action_of(FrozenLakeParams(), {"nope": 1.0})
    for short_or_long in [(0.5, 0.5), (0.25, 0.25, 0.25, 0.25)]:
        with pytest.raises(ValueError, match="has 3"):
            interface.action_of(FrozenLakeParams(), {"slip": short_or_long})
    action = interface.action_of(FrozenLakeParams(), {"slip": (1.0, 0.0, 0.0)})
    assert action.shape == (3,) and action.dtype == np.float32


@pytest.mark.parametrize("number", [float, np.float32])
@pytest.mark.parametrize("mode", ["normalized", "delta"])
@pytest.mark.parametrize("lake", [False, True], ids=["CartPole", "FrozenLake"])
def test_action_of_is_the_clipped_scaled_change_of_the_flat_theta(
    lake: bool, mode: str, number: type
) -> None:
    """Element by element: (proposed - current) / allowance (normalised), clipped to the space.

    In float64 whatever the proposal's number type (a NumPy float32 one included).
    """
    from ns_pz.envs.cartpole import CartPoleFamily
    from ns_pz.envs.frozen_lake import FrozenLakeFamily

    from ns_pz.nature.interface import NatureInterface

    family = FrozenLakeFamily() if lake else CartPoleFamily()
    theta = family.default_params()
    interface = NatureInterface(family, theta, NatureConstraints(), 500, action=mode)
    space = interface.action_space
    scale = np.where(interface.allowance > 0.0, interface.allowance, 1.0)
    layout = theta.flat_layout()
    rng = np.random.default_rng(5)
    for _ in range(200):
        target = theta.flat()
        proposal = {}
        for spec, start, stop in layout:
            if rng.random() < 0.5:
                moved = target[start:stop] + rng.normal(size=stop - start) * 10.0 ** rng.integers(
                    -4, 4
                )
                values = [number(v) for v in moved]
                target[start:stop] = values  # what the proposal holds, as float64
                proposal[spec.name] = values[0] if stop - start == 1 else tuple(values)
        change = target - theta.flat()
        if mode == "normalized":
            change /= scale
        expected = np.clip(change, space.low.astype(np.float64), space.high.astype(np.float64))
        action = interface.action_of(theta, proposal)
        assert action.dtype == space.dtype
        assert action.tobytes() == expected.astype(space.dtype).tobytes()
        action[:] = 7.0  # the caller's own array: no later action starts from it


@pytest.mark.parametrize(
    "space",
    [
        spaces.Box(-2.0, 2.0, (4,), np.float32),
        spaces.Box(-1e9, 1e9, (2, 3), np.float64),
        spaces.Box(0, 10, (3,), np.int64),
        spaces.Discrete(5, start=-2),
        spaces.MultiDiscrete([3, 2]),
    ],
    ids=["box32", "box64-2d", "box-int", "discrete", "multidiscrete"],
)
def test_nature_sees_states_and_actions_exactly_as_gymnasium_flattens_them(space):
    """The values behind nature's view of the agent's state and action: ``spaces.flatten``."""
    from ns_pz.nature.interface import _flat_values_of

    space.seed(0)
    flat = _flat_values_of(space)
    for _ in range(50):
        x = space.sample()
        expected = spaces.flatten(space, x)
        got = flat(x)
        assert np.array(got, np.float32).tobytes() == expected.astype(np.float32).tobytes()
        assert len(got) == spaces.flatdim(space)


def test_delta_actions_that_sum_to_nan_are_refused_even_where_the_space_is_unbounded():
    """+inf and -inf in one Δθ (possible where parameters are unbounded) make no proposal."""
    from dataclasses import dataclass
    from types import SimpleNamespace

    from ns_pz.nature.interface import NatureInterface
    from ns_pz.params import Params, scalar

    @dataclass(frozen=True, slots=True)
    class Open(Params):
        up: float = scalar(1.0, high=5.0)
        down: float = scalar(1.0, low=0.0)

    family = SimpleNamespace(params_cls=Open, observation_space=None, action_space=None)
    interface = NatureInterface(family, Open(), NatureConstraints(), 10, action="delta")
    assert interface.action_space.high[0] == np.inf
    for action in ([np.inf, -np.inf], [np.nan, 0.0]):
        with pytest.raises(ValueError, match="outside the action space"):
            interface.proposal(np.array(action), Open())
    assert interface.proposal(np.array([np.inf, 0.0]), Open()) == {"up": np.inf}


def test_trajectory_nature_checks_what_it_replays():
    """Bad recordings are refused up front.

    Non-int or negative times, values that are no parameter sets, another family's values (2.9
    became 2, -1 passed, dicts failed mid-episode).
    """
    import ns_pz
    from ns_pz.nature import TrajectoryNature

    cart = CartPoleParams(masspole=0.2)
    with pytest.raises(TypeError, match="2.9 is not an int step"):
        TrajectoryNature([2.9], [cart])
    with pytest.raises(ValueError, match="steps >= 0"):
        TrajectoryNature([-1], [cart])
    with pytest.raises(TypeError, match="parameter sets of one class"):
        TrajectoryNature([1], [{"masspole": 0.2}])
    with pytest.raises(TypeError, match="parameter sets of one class"):
        TrajectoryNature([1, 2], [cart, FrozenLakeParams()])
    with pytest.raises(TypeError, match="recorded FrozenLakeParams values"):
        ns_pz.make_gym("ns_pz/CartPole-v0", nature=TrajectoryNature([1], [FrozenLakeParams()]))
    replayed = ns_pz.make_gym(
        "ns_pz/CartPole-v0", nature=TrajectoryNature((t for t in [np.int64(1)]), [cart])
    )
    replayed.reset(seed=0)
    replayed.step(0)
    replayed.step(0)
    assert replayed.ground_truth().change_values == (cart,)


def test_budget_bounded_increment_stops_at_its_budget_without_a_rounding_step():
    """Two firings of 0.2 spend B = 0.4 up to rounding; a third does not move.

    It made a change of 1e-16, which the oracle notified.
    """
    import ns_pz
    from ns_pz.nature import BudgetBoundedIncrement, ContinuousScheduler, ScriptedNature

    rule = BudgetBoundedIncrement(ContinuousScheduler(start=0), k=-0.2, B=0.4)
    env = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0",
        params={"slip": (1.0, 0.0, 0.0, 0.0)},
        nature=ScriptedNature({"slip": rule}),
        notification="detailed",
    )
    env.reset(seed=0)
    flagged = [bool(env.step(0)[0]["env_change"].any()) for _ in range(5)]
    assert env.ground_truth().change_times == (0, 1)
    assert flagged == [True, True, False, False, False]


def test_constraints_hash_and_an_endless_window_is_named():
    """A frozen NatureConstraints hashes (its derived dicts took part); end=inf points to None."""
    from ns_pz.nature import ContinuousScheduler, NatureConstraints

    assert len({NatureConstraints(lipschitz=0.1), NatureConstraints(lipschitz=0.1)}) == 1
    per_param = [NatureConstraints(lipschitz={"a": 0.1}, budget={"a": 1.0}) for _ in "ab"]
    assert len(set(per_param)) == 1
    assert NatureConstraints(lipschitz=0.1) != NatureConstraints(lipschitz=0.2)
    with pytest.raises(TypeError, match="no end: end=None"):
        ContinuousScheduler(start=0, end=math.inf)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="must be an int"):
        ContinuousScheduler(start=0, end=np.array([5, 6]))  # type: ignore[arg-type]


def test_constraints_keep_their_own_copy_of_a_mapping():
    """The caller's dict changed later: equality, hash and repr followed it, enforcement not."""
    from ns_pz.nature import NatureConstraints

    limits = {"masspole": 0.1}
    constraints = NatureConstraints(lipschitz=limits)
    seen = {constraints}
    limits["masspole"] = 0.5
    assert constraints in seen and constraints.lipschitz == {"masspole": 0.1}


def test_movable_freezes_the_parameters_it_does_not_name():
    """A proposal for a frozen parameter is dropped; the movable ones are projected as ever."""
    theta = CartPoleParams()
    frozen = NatureConstraints(movable=("length",), lipschitz={"length": 0.1})
    new, sizes = admit(theta, {"length": 0.9, "gravity": 20.0, "masspole": 0.5}, frozen, {})
    assert (new.gravity, new.masspole) == (theta.gravity, theta.masspole)
    assert new.length == pytest.approx(theta.length + 0.1)
    assert set(sizes) == {"length"}
    assert frozen.moves("length") and not frozen.moves("gravity")
    assert NatureConstraints().moves("gravity")
    assert hash(frozen) == hash(NatureConstraints(movable=("length",), lipschitz={"length": 0.1}))
    with pytest.raises(UnknownParam, match="lenght"):
        NatureConstraints(movable=("lenght",)).check_names(CartPoleParams)


@pytest.mark.parametrize(
    ("movable", "error", "match"),
    [
        ("length", TypeError, r"movable='length' must be a tuple of parameter names"),
        ((), ValueError, r"movable=\(\) freezes every parameter"),
        (("length", "length"), ValueError, "names a parameter twice"),
        ((1,), TypeError, r"movable=\(1,\) must be a tuple"),
    ],
)
def test_movable_is_checked(movable: object, error: type, match: str) -> None:
    """A bare string, nothing, a repeated name or a non-string is refused, naming the value."""
    with pytest.raises(error, match=match):
        NatureConstraints(movable=movable)  # type: ignore[arg-type]


def test_a_schedule_of_a_frozen_parameter_is_refused():
    """A scripted nature that moves a parameter ``movable`` freezes is a contradiction."""
    import ns_pz

    nature = ScriptedNature({"gravity": IncrementUpdate(ContinuousScheduler(start=1), k=0.1)})
    with pytest.raises(ValueError, match=r"nature schedules \['gravity'\], which constraints"):
        ns_pz.make(
            "ns_pz/CartPole-v0", nature=nature, constraints=NatureConstraints(movable=("length",))
        )
