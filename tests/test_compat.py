"""ns_pz.compat: NS-Gym's API over the ns_pz core.

Expected numbers come from NS-Gym's documented formulas (see the compat docstrings), never from
pasted runs; where ns_pz differs on purpose the test says which NS-Gym defect it covers.
"""

from __future__ import annotations

import copy
import math
import pickle
import re
import textwrap
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ns_pz.compat
from ns_pz import ResetNeeded
from ns_pz.compat import base, schedulers, wrappers
from ns_pz.compat import update_functions as uf
from ns_pz.compat.families import CLASSIC_CONTROL
from ns_pz.compat.schedulers import (
    BurstScheduler,
    ContinuousScheduler,
    CustomScheduler,
    DecayingProbabilityScheduler,
    DiscreteScheduler,
    MemorylessScheduler,
    PeriodicScheduler,
    RandomScheduler,
    WindowScheduler,
)
from ns_pz.compat.update_functions import (
    BudgetBoundedIncrement,
    DeterministicTrend,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionNoUpdate,
    DistributionStepWiseUpdate,
    ExponentialDecay,
    IncrementUpdate,
    LCBoundedDistributionUpdate,
    LCBoundedDistrubutionUpdate,
    NoUpdate,
    RandomCategorical,
    RandomWalk,
    StepWiseUpdate,
    TargetReversion,
    UniformDrift,
)
from ns_pz.compat.wrappers import (
    NSBridgeWrapper,
    NSClassicControlWrapper,
    NSCliffWalkingWrapper,
    NSFrozenLakeWrapper,
)
from ns_pz.nature import ContinuousScheduler as NativeContinuous
from ns_pz.nature import IncrementUpdate as NativeIncrement

PAPER_LISTING = """
import gymnasium as gym
from ns_pz.compat.wrappers import *
from ns_pz.compat.schedulers import *
from ns_pz.compat.update_functions import *
env = gym.make("CartPole-v1")
scheduler_1 = ContinuousScheduler()
scheduler_2 = PeriodicScheduler(period=3)
U_Fn_1 = IncrementUpdate(scheduler_1, k=0.1)
U_Fn_2 = RandomWalk(scheduler_2)
tunable_params = {"masspole": U_Fn_1, "gravity": U_Fn_2}
ns_env = NSClassicControlWrapper(env, tunable_params, change_notification=True)
obs, info = ns_env.reset()
planning_env = ns_env.get_planning_env()
"""


def fired(scheduler, steps=12):
    """Steps 0..steps-1 at which an NS-Gym-style scheduler fires."""
    return [t for t in range(steps) if scheduler(t)]


def quiet_check_env(env):
    """Gymnasium's env checker, its style warnings (infinite Box bounds, ...) silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env)


# -- the paper listing ------------------------------------------------------------------------
def test_paper_listing_runs_unchanged_but_for_the_package_name():
    """The NS-Gym paper's listing runs unchanged but for the package name.

    Then the steps follow its schedule: masspole +0.1 each step, gravity at steps 1 and 4
    (t = 0 and 3); flags shown, sizes hidden (no delta notification).
    """
    namespace: dict = {}
    exec(textwrap.dedent(PAPER_LISTING), namespace)  # noqa: S102 - the listing under test
    ns_env, obs, info = namespace["ns_env"], namespace["obs"], namespace["info"]
    planning_env = namespace["planning_env"]
    assert set(obs) == {"state", "env_change", "delta_change", "relative_time"}
    assert obs["env_change"] == {"masspole": 0, "gravity": 0}
    assert obs["relative_time"] == 0
    assert info == {
        "Ground Truth Env Change": {"masspole": 0, "gravity": 0},
        "Ground Truth Delta Change": {"masspole": 0, "gravity": 0},
    }
    assert isinstance(planning_env, NSClassicControlWrapper) and planning_env.is_sim_env
    gravity = [ns_env.get_params()["gravity"]]
    for step in range(1, 5):
        obs, reward, terminated, truncated, info = ns_env.step(step % 2)
        assert obs["relative_time"] == step and reward == 1.0 and type(reward) is float
        gravity_moved = ns_env.get_params()["gravity"] != gravity[-1]
        gravity.append(ns_env.get_params()["gravity"])
        assert obs["env_change"] == {"masspole": 1, "gravity": int(step in (1, 4))}
        assert gravity_moved == (step in (1, 4))
        assert obs["delta_change"] == {"masspole": 0.0, "gravity": 0.0}
        assert ns_env.get_params()["masspole"] == pytest.approx(0.1 + 0.1 * step)
    # Without delta notification the planning env gets the initial parameters.
    assert ns_env.get_planning_env().get_params()["masspole"] == 0.1
    assert ns_env.get_planning_env().get_params()["gravity"] == 9.8


# -- schedulers -------------------------------------------------------------------------------
def test_schedulers_use_nsgym_windows_and_absolute_time():
    """start=0 / end=inf defaults, inclusive window, periods and bursts on absolute t."""
    assert fired(ContinuousScheduler()) == list(range(12))
    assert fired(ContinuousScheduler(start=2, end=4)) == [2, 3, 4]
    assert fired(PeriodicScheduler(period=3, start=2)) == [3, 6, 9]
    assert fired(PeriodicScheduler(period=3)) == [0, 3, 6, 9]
    assert fired(DiscreteScheduler({1, 5})) == [1, 5]
    assert "".join(str(int(BurstScheduler(2, 3)(t))) for t in range(10)) == "1100011000"
    assert fired(WindowScheduler([(1, 2), (6, 7)], end=6)) == [1, 2, 6]
    assert fired(CustomScheduler(lambda t: t % 5 == 0, start=1)) == [5, 10]
    assert PeriodicScheduler(2)(np.int64(4)) is True  # NS-Gym: AssertionError (D4)


def test_random_schedulers_draw_from_their_seeded_generator_standalone():
    """Standalone, a seeded scheduler draws one uniform per in-window call.

    Same seed, same pattern; decaying probability is p0 exp(-rate t) on absolute t.
    """
    assert fired(RandomScheduler(0.5, seed=4), 40) == fired(RandomScheduler(0.5, seed=4), 40)
    rng = np.random.default_rng(4)
    assert fired(RandomScheduler(0.3, seed=4), 40) == [t for t in range(40) if rng.random() < 0.3]
    rng = np.random.default_rng(9)
    expected = [t for t in range(2, 40) if rng.random() < 0.8 * math.exp(-0.05 * t)]
    assert fired(DecayingProbabilityScheduler(0.8, 0.05, start=2, seed=9), 40) == expected
    memoryless = MemorylessScheduler(0.3, seed=1)
    assert 0 not in fired(memoryless, 40)
    evens = [t for t in range(0, 2000, 2) if memoryless(t)]
    assert 200 < len(evens) < 400  # keeps firing although odd steps are skipped


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: ContinuousScheduler(start=-1), ValueError, r"start=-1 must be a time step >= 0"),
        (lambda: ContinuousScheduler(start=5, end=2), ValueError, r"end=2 is before start=5"),
        (lambda: PeriodicScheduler(period=0), ValueError, r"period=0 must be >= 1"),
        (lambda: RandomScheduler(1.5), ValueError, r"probability=1.5 must lie in \[0, 1\]"),
        (lambda: DiscreteScheduler({1, 9}, end=5), ValueError, r"event_list has steps \[9\]"),
        (lambda: CustomScheduler(3), TypeError, r"event_function=3 must be callable"),
        (lambda: ContinuousScheduler()("x"), TypeError, r"t='x' must be an int or float"),
        (lambda: ContinuousScheduler()(math.nan), ValueError, r"t=nan must be a time step"),
        (lambda: RandomWalk(ContinuousScheduler(), seed="a"), TypeError, r"seed='a' must be"),
    ],
)
def test_compat_arguments_are_checked(build, error, match):
    """What NS-Gym asserts (or accepts) raises a clear error here."""
    with pytest.raises(error, match=match):
        build()


# -- update functions -------------------------------------------------------------------------
def test_update_calling_convention():
    """fn(param, t) -> (value, flag, delta); no firing gives (param, 0, 0.0)."""
    inc = IncrementUpdate(PeriodicScheduler(2), k=0.25)
    assert inc(1.0, 0) == (1.25, 1, 0.25)
    assert inc(1.0, 1) == (1.0, 0, 0.0)
    assert inc.prev_time == 1 and inc.prev_param == 1.0
    assert NoUpdate(ContinuousScheduler())(3.0, 0) == (3.0, 0, 0.0)  # NS-Gym: flag 1


def test_stepwise_does_not_consume_the_list_and_stops_flagging_when_used_up():
    """D3: once the list is used up, no change is reported; the caller's list stays whole."""
    values = [1.0]
    stepwise = StepWiseUpdate(ContinuousScheduler(), values)
    assert [stepwise(0.5, t) for t in range(3)] == [(1.0, 1, 0.5), (0.5, 0, 0.0), (0.5, 0, 0.0)]
    assert values == [1.0]


def test_accumulating_rules_keep_nsgym_numbers():
    """Trend and decay compound on the current value, as NS-Gym's.

    DeterministicTrend adds slope*t (slope 1: 0, 1, 3, 6, 10); ExponentialDecay multiplies by
    exp(-rate t) (1.0 -> exp(-rate t(t+1)/2)).
    """
    trend = DeterministicTrend(ContinuousScheduler(), slope=1.0)
    value, path = 0.0, []
    for t in range(5):
        value, _, _ = trend(value, t)
        path.append(value)
    assert path == [t * (t + 1) / 2 for t in range(5)]
    decay = ExponentialDecay(ContinuousScheduler(), decay_rate=0.1)
    value, path = 1.0, []
    for t in range(4):
        value, _, _ = decay(value, t)
        path.append(value)
    assert path == pytest.approx([math.exp(-0.1 * t * (t + 1) / 2) for t in range(4)])


def test_distribution_updates_take_and_return_lists_and_refuse_bad_vectors():
    """NS-Gym's increment/decrement rules; total-variation deltas; D1: bad vectors refused."""
    down = DistributionDecrementUpdate(ContinuousScheduler(), k=0.3)
    value, flag, delta = down([0.2, 0.7, 0.1], 0)
    assert value == pytest.approx([0.0, 0.5, 0.5]) and flag == 1
    assert delta == pytest.approx(0.5 * (0.2 + 0.2 + 0.4))
    up = DistributionIncrementUpdate(ContinuousScheduler(), k=0.3)
    assert up([0.9, 0.1, 0.0], 0)[0] == pytest.approx([1.0, 0.0, 0.0])
    assert DistributionNoUpdate(ContinuousScheduler())([0.5, 0.5], 0) == ([0.5, 0.5], 0, 0.0)
    with pytest.raises(ValueError, match=r"param=\[0.5, 0.2, 0.2\] sums to 0.9"):
        down([0.5, 0.2, 0.2], 1)
    with pytest.raises(ValueError, match=r"update_values\[0\]=\[0.5, 0.2, 0.2\] sums to 0.9"):
        DistributionStepWiseUpdate(DiscreteScheduler({0}), [[0.5, 0.2, 0.2]])
    with pytest.raises(ValueError, match=r"rate=1.5 must lie in \[0.0, 1.0\]"):
        UniformDrift(ContinuousScheduler(), rate=1.5)
    with pytest.raises(ValueError, match=r"target=\[2, 0, 0\] sums to 2"):
        TargetReversion(ContinuousScheduler(), target=[2, 0, 0], theta=0.5)


def test_lipschitz_bounded_update_bounds_by_time_since_the_previous_call():
    """The bound is L * |t - prev_time| (prev_time -1 before the first call).

    The misspelt NS-Gym name is the same class; an inner update may be given as a class.
    """
    assert LCBoundedDistrubutionUpdate is LCBoundedDistributionUpdate
    bounded = LCBoundedDistrubutionUpdate(
        ContinuousScheduler(), L=0.05, update_fn=UniformDrift(ContinuousScheduler(), rate=1.0)
    )
    value, _, delta = bounded([1.0, 0.0, 0.0], 0)
    assert delta == pytest.approx(0.05)  # L * (0 - (-1))
    value, _, delta = bounded(value, 4)
    assert delta == pytest.approx(0.2)  # L * (4 - 0)
    by_class = LCBoundedDistrubutionUpdate(
        ContinuousScheduler(), L=0.1, update_fn=RandomCategorical
    )
    assert by_class([1 / 3] * 3, 0)[2] <= 0.1 + 1e-12
    with pytest.raises(TypeError, match="must be an ns_pz.compat distribution update"):
        LCBoundedDistrubutionUpdate(ContinuousScheduler(), L=0.1, update_fn=IncrementUpdate)


def test_budget_bounded_increment_can_be_built_and_spends_its_budget():
    """D2: NS-Gym's cannot be constructed; this one moves 0.1 a firing until 0.15 is spent."""
    budget = BudgetBoundedIncrement(ContinuousScheduler(), k=0.1, B=0.15)
    first = budget([0.5, 0.25, 0.25], 0)
    second = budget(first[0], 1)
    third = budget(second[0], 2)
    assert first[0] == pytest.approx([0.6, 0.2, 0.2]) and first[2] == pytest.approx(0.1)
    assert second[0] == pytest.approx([0.65, 0.175, 0.175]) and second[2] == pytest.approx(0.05)
    assert third == (pytest.approx(second[0]), 0, 0.0)


def test_random_updates_are_reproducible_by_their_seed_standalone():
    """seed= seeds standalone calls; seed() reseeds."""
    walk_a, walk_b = (
        RandomWalk(ContinuousScheduler(), seed=3),
        RandomWalk(ContinuousScheduler(), seed=3),
    )
    assert [walk_a(0.0, t)[0] for t in range(5)] == [walk_b(0.0, t)[0] for t in range(5)]
    walk_a.seed(7)
    walk_b.seed(7)
    assert walk_a(0.0, 0) == walk_b(0.0, 0)
    rng = np.random.default_rng(11)
    assert RandomWalk(ContinuousScheduler(), mu=1.0, sigma=2.0, seed=11)(0.0, 0)[
        0
    ] == pytest.approx(1.0 + 2.0 * rng.standard_normal())


def test_star_imports_match_nsgym_modules():
    """update_functions re-exports single_param and distribution, as NS-Gym's package does."""
    names = set(uf.__all__)
    assert set(uf.single_param.__all__) | set(uf.distribution.__all__) == names
    assert len(uf.single_param.__all__) == 17 and "LCBoundedDistrubutionUpdate" in names
    assert len(schedulers.__all__) == 9
    assert {"Scheduler", "UpdateFn", "UpdateDistributionFn", "Reward", "TUNABLE_PARAMS"} <= set(
        base.__all__
    )
    assert base.TUNABLE_PARAMS["CartPoleEnv"]["masspole"] == 0.1
    assert base.TUNABLE_PARAMS["FrozenLakeEnv"] == {"P": [1.0, 0.0, 0.0]}


# -- subclasses written for NS-Gym ------------------------------------------------------------
class EveryOther(base.Scheduler):
    """A user scheduler: fires on even steps."""

    def _check(self, t):
        return t % 2 == 0


class CountingUpdate(base.UpdateFn):
    """A user update with state: adds the number of earlier firings + 1."""

    def __init__(self, scheduler):
        super().__init__(scheduler)
        self.count = 0

    def _update(self, param, t):
        self.count += 1
        return param + self.count


def test_user_subclasses_run_standalone_and_fresh_in_every_episode():
    """A user scheduler and a stateful user update: the wrapper runs a per-episode copy."""
    fn = CountingUpdate(EveryOther())
    assert [fn(0.0, t)[0] for t in range(4)] == [1.0, 0.0, 2.0, 0.0]
    env = NSClassicControlWrapper(gym.make("CartPole-v1"), {"length": CountingUpdate(EveryOther())})
    for _ in range(2):
        env.reset(seed=0)
        lengths = []
        for _ in range(5):
            env.step(0)
            lengths.append(env.get_params()["length"])
        assert lengths == pytest.approx([1.5, 1.5, 3.5, 3.5, 6.5])


# -- wrappers ---------------------------------------------------------------------------------
def cartpole(tunable, **kwargs):
    """A CartPole wrapper around a fresh gym.make."""
    return NSClassicControlWrapper(gym.make("CartPole-v1"), tunable, **kwargs)


def test_notification_levels_and_signed_deltas():
    """none: zeros; basic: flags; detailed: flags and the signed change (NS-Gym's new - old)."""

    def first_step(**kwargs):
        env = cartpole({"masspole": uf.DecrementUpdate(ContinuousScheduler(), k=0.05)}, **kwargs)
        env.reset(seed=1)
        return env.step(0)[0]

    assert first_step()["env_change"] == {"masspole": 0}
    basic = first_step(change_notification=True)
    assert basic["env_change"] == {"masspole": 1} and basic["delta_change"] == {"masspole": 0.0}
    detailed = first_step(change_notification=True, delta_change_notification=True)
    assert detailed["delta_change"]["masspole"] == pytest.approx(-0.05)


def test_freeze_hides_notifications_but_parameters_keep_changing():
    """NS-Gym's freeze: notifications zeroed, θ still moves; unfreeze shows them again."""
    env = cartpole(
        {"masspole": IncrementUpdate(ContinuousScheduler(), k=0.1)},
        change_notification=True,
        delta_change_notification=True,
    )
    env.reset(seed=0)
    assert env.freeze() is env
    obs = env.step(0)[0]
    assert obs["env_change"] == {"masspole": 0} and env.get_params()["masspole"] == pytest.approx(
        0.2
    )
    env.unfreeze()
    assert env.step(0)[0]["env_change"] == {"masspole": 1}


def test_ground_truth_info_has_nsgym_keys_and_types():
    """The info dict holds NS-Gym's two ground-truth keys, unmasked (issue 9, item 10).

    NS-Gym 1.0.12 (FrozenLake, DistributionDecrementUpdate(ContinuousScheduler(), k=0.1),
    basic notification) gives at reset ``{"Ground Truth Env Change": {"P": 0},
    "Ground Truth Delta Change": {"P": 0}}`` (two ints) and after a step ``{"P": 1}`` (int) and
    a float size (ns_pz's is the total variation 0.1, NS-Gym's W1 over positions 0.15), plus
    ``"transition_prob"``. ``ground_truth_info=False`` leaves the two keys out.
    """
    tunable = {"P": DistributionDecrementUpdate(ContinuousScheduler(), k=0.1)}
    lake = NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), tunable, change_notification=True)
    _, info = lake.reset(seed=0)
    assert info == {wrappers.GROUND_TRUTH_CHANGE: {"P": 0}, wrappers.GROUND_TRUTH_DELTA: {"P": 0}}
    assert [type(v["P"]) for v in info.values()] == [int, int]
    obs, _, _, _, info = lake.step(2)
    assert info[wrappers.GROUND_TRUTH_CHANGE] == {"P": 1} == obs["env_change"]
    assert type(info[wrappers.GROUND_TRUTH_CHANGE]["P"]) is int
    assert type(info[wrappers.GROUND_TRUTH_DELTA]["P"]) is float
    assert info[wrappers.GROUND_TRUTH_DELTA]["P"] == pytest.approx(0.1)
    assert obs["delta_change"] == {"P": 0.0}  # masked: no delta notification, truth unmasked
    assert info["transition_prob"] == pytest.approx([0.9, 0.05, 0.05])
    quiet = NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), tunable, ground_truth_info=False)
    assert quiet.reset(seed=0)[1] == {}
    assert set(quiet.step(2)[4]) == {"transition_prob"}
    cart = cartpole({"masspole": IncrementUpdate(ContinuousScheduler(), k=0.1)})
    cart.reset(seed=0)
    info = cart.step(0)[4]
    assert info[wrappers.GROUND_TRUTH_DELTA]["masspole"] == pytest.approx(0.1)
    assert info[wrappers.GROUND_TRUTH_CHANGE] == {"masspole": 1}


@pytest.mark.parametrize(("change", "delta"), [(False, False), (True, False), (True, True)])
def test_ground_truth_sizes_are_the_total_variation_at_every_level(change, delta):
    """Recorded by nature's change (basic, detailed) or computed (none): the same TV size."""
    from ns_pz.envs.cliff_walking import CliffWalkingParams

    tunable = {"P": DistributionDecrementUpdate(ContinuousScheduler(), k=0.01)}
    cliff = NSCliffWalkingWrapper(
        gym.make("CliffWalking-v1"),
        tunable,
        change_notification=change,
        delta_change_notification=delta,
        initial_prob_dist=[1.0, 0.0, 0.0, 0.0],
    )
    cliff.reset(seed=0)
    process = cliff.process
    for _ in range(5):
        _, _, _, _, info = cliff.step(0)
        before, after = process.last_change
        recorded = process.last_change_sizes
        assert (recorded is None) is (not change)  # level none computes no sizes
        if recorded is not None:
            with pytest.raises(TypeError):  # a read-only view: the process keeps its own
                recorded["slip"] = 1.0  # type: ignore[index]
        size = CliffWalkingParams.spec("slip").distance(before.slip, after.slip)
        assert info[wrappers.GROUND_TRUTH_DELTA]["P"] == size > 0.0
        assert info["transition_prob"] == list(process.last_theta.slip)
    process.set_params({"slip": (0.5, 0.5, 0.0, 0.0)})  # by hand, after nature's change
    info = cliff.step(0)[4]
    assert process.last_change_sizes is None  # two changes in one step: sizes not recorded
    before, after = process.last_change
    size = CliffWalkingParams.spec("slip").distance(before.slip, after.slip)
    assert info[wrappers.GROUND_TRUTH_DELTA]["P"] == size


def theta_path(env, seed, steps=15):
    """Parameters after each step of one episode (action 0 throughout)."""
    env.reset(seed=seed)
    out = []
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(0)
        out.append(env.get_params())
        if terminated or truncated:
            break
    return out


def test_random_schedules_follow_the_reset_seed():
    """D6: same seed, same θ trajectory; another seed or an unseeded episode differs."""
    tunable = {"masspole": RandomWalk(RandomScheduler(0.5), sigma=0.01)}
    env = cartpole(tunable)
    first = theta_path(env, 3)
    assert first == theta_path(cartpole(tunable), 3)
    assert first != theta_path(env, 4)
    env.reset(seed=3)
    unseeded = [theta_path(env, None) for _ in range(2)]
    assert unseeded[0] != unseeded[1]


def test_reset_brings_back_the_initial_slip_and_the_dynamics_follow_it():
    """D14: after an episode that changed the slip, the next starts from [1, 0, 0].

    And it moves deterministically (NS-Gym samples from the previous episode's table).
    """
    tunable = {"P": DistributionDecrementUpdate(DiscreteScheduler({1}), k=0.5)}
    lake = NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), tunable)
    for seed in range(30):
        lake.reset(seed=seed)
        assert lake.get_params()["P"] == [1.0, 0.0, 0.0]
        assert lake.step(2)[0]["state"] == 1  # RIGHT from 0, no slip at t = 0
        lake.step(1)  # the slip changes here (t = 1)
        assert lake.get_params()["P"] == pytest.approx([0.5, 0.25, 0.25])


def test_wrapper_is_the_core_with_the_same_seed():
    """One implementation: the wrapper's states equal ns_pz's own env built alike."""
    from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

    from ns_pz import NSGymEnv
    from ns_pz.nature import DistributionDecrementUpdate as NativeDecrement
    from ns_pz.nature import ScriptedNature

    tunable = {"P": DistributionDecrementUpdate(ContinuousScheduler(), k=0.02)}
    lake = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1", map_name="8x8"), tunable, initial_prob_dist=[0.8, 0.1, 0.1]
    )
    native = NSGymEnv(
        FrozenLakeFamily(map_name="8x8"),
        params=FrozenLakeParams(slip=(0.8, 0.1, 0.1)),
        nature=ScriptedNature({"slip": NativeDecrement(NativeContinuous(start=0), k=0.02)}),
        max_episode_steps=200,
    )
    actions = np.random.default_rng(0).integers(4, size=60)
    lake.reset(seed=5)
    native.reset(seed=5)
    for action in actions:
        ours = lake.step(int(action))
        theirs = native.step(int(action))
        assert ours[0]["state"] == theirs[0]["state"] and ours[2] == theirs[2]
        if ours[2]:
            break


def test_parameters_and_map_come_from_the_env_passed():
    """θ_0 is read from the env's attributes; the FrozenLake map and time limit too."""
    env = gym.make("CartPole-v1")
    env.unwrapped.masspole = 0.3
    wrapped = NSClassicControlWrapper(env, {})
    wrapped.reset(seed=0)
    assert wrapped.get_params()["masspole"] == 0.3
    lake = NSFrozenLakeWrapper(gym.make("FrozenLake-v1", map_name="8x8"), {})
    assert lake.observation_space["state"].n == 64 and lake.core.process.max_episode_steps == 100
    short = NSCliffWalkingWrapper(gym.make("CliffWalking-v1", max_episode_steps=3), {})
    short.reset(seed=0)
    assert [short.step(0)[3] for _ in range(3)] == [False, False, True]


def test_planning_env_parameters_follow_nsgym_rules():
    """Planning envs get θ_0, or the current θ with delta notification or in a sim env.

    θ is frozen in them unless in_sim_change; the clock and the map carry over (D10, D11).
    """
    tunable = {"P": DistributionDecrementUpdate(ContinuousScheduler(), k=0.1)}
    lake = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1", map_name="8x8"), tunable, change_notification=True
    )
    lake.reset(seed=0)
    lake.step(2)
    lake.step(2)
    plan = lake.get_planning_env()
    assert plan.get_params()["P"] == [1.0, 0.0, 0.0] and plan.t == 2 and plan.is_sim_env
    assert plan.observation_space["state"].n == 64
    assert plan.step(2)[0]["env_change"] == {"P": 0}  # frozen
    assert lake.get_params()["P"] == pytest.approx([0.8, 0.1, 0.1])  # the real env is untouched
    detailed = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1"), tunable, change_notification=True, delta_change_notification=True
    )
    detailed.reset(seed=0)
    detailed.step(2)
    assert detailed.get_planning_env().get_params()["P"] == pytest.approx([0.9, 0.05, 0.05])
    assert copy.deepcopy(lake).get_params()["P"] == pytest.approx([0.8, 0.1, 0.1])
    moving = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1"),
        tunable,
        in_sim_change=True,
        delta_change_notification=True,
        change_notification=True,
    )
    moving.reset(seed=0)
    moving.step(2)
    sim = moving.get_planning_env()
    assert sim.step(2)[0]["env_change"] == {"P": 1}
    assert sim.get_params()["P"] == pytest.approx([0.8, 0.1, 0.1])
    with pytest.raises(ResetNeeded, match="before reset"):
        NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), tunable).get_planning_env()


def test_planning_envs_are_reproducible_from_the_seed():
    """D7: a planning env with in-sim change draws from generators derived from the seed."""

    def planned(seed):
        env = cartpole(
            {"gravity": RandomWalk(ContinuousScheduler())},
            in_sim_change=True,
            change_notification=True,
            delta_change_notification=True,
        )
        env.reset(seed=seed)
        env.step(0)
        sim = env.get_planning_env()
        return [sim.step(0)[0]["delta_change"]["gravity"] for _ in range(3)]

    assert planned(2) == planned(2) != planned(3)


def test_persistent_params_and_reward_objects():
    """persistent_params carries θ across resets; scalar_reward=False returns a Reward."""
    env = cartpole(
        {"masspole": IncrementUpdate(ContinuousScheduler(), k=0.1)},
        persistent_params=True,
        scalar_reward=False,
        change_notification=True,
    )
    env.reset(seed=0)
    _, reward, _, _, _ = env.step(0)
    assert reward == base.Reward(1.0, {"masspole": 1}, {"masspole": 0.0}, 1)
    env.reset()
    assert env.get_params()["masspole"] == pytest.approx(0.2)
    env.step(0)
    assert env.get_params()["masspole"] == pytest.approx(0.3)


def test_grid_rewards_and_terminal_cliff():
    """modified_rewards for FrozenLake; CliffWalking's NS-Gym rewards and terminal cliff."""
    lake = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1", desc=["SG"]), {}, modified_rewards={"G": 10.0}
    )
    lake.reset(seed=0)
    assert lake.step(2)[1:3] == (10.0, True)
    cliff = NSCliffWalkingWrapper(gym.make("CliffWalking-v1"), {}, terminal_cliff=True)
    cliff.reset(seed=0)
    obs, reward, terminated, _, _ = cliff.step(1)  # RIGHT from the start: into the cliff
    assert (obs["state"], reward, terminated) == (36, -100.0, True)
    cliff = NSCliffWalkingWrapper(gym.make("CliffWalking-v1"), {})
    cliff.reset(seed=0)
    assert cliff.step(1)[1:3] == (-100.0, False)
    rewards = [cliff.step(a)[1] for a in [0] + [1] * 11 + [2]]
    assert rewards == [-1.0] * 12 + [0.0]  # NS-Gym's goal reward is 0


def test_bridge_id_and_its_seeding():
    """The Bridge is registered apart from NS-Gym's id; D9: its slips follow reset(seed)."""
    assert ns_pz.compat.BRIDGE_ID == "ns_pz_compat/Bridge-v0"
    env = gym.make(ns_pz.compat.BRIDGE_ID, global_init_probs=[0.5, 0.25, 0.25])
    assert env.spec.max_episode_steps == 100

    def walk(seed):
        state, _ = env.reset(seed=seed)
        states = [state]
        for _ in range(6):
            state, _, terminated, truncated, _ = env.step(0)
            states.append(state)
            if terminated or truncated:
                break
        return states

    assert walk(3) == walk(3)
    assert len({tuple(walk(s)) for s in range(10)}) > 1
    split = NSBridgeWrapper(
        gym.make(ns_pz.compat.BRIDGE_ID, split_probs=True),
        {"P_right": UniformDrift(ContinuousScheduler(), rate=0.5)},
        change_notification=True,
    )
    split.reset(seed=0)
    assert split.step(0)[0]["env_change"] == {"P_right": 1}
    assert split.get_params()["P_left"] == [1.0, 0.0, 0.0]


@pytest.mark.parametrize(
    "build",
    [
        lambda: cartpole(
            {"masspole": IncrementUpdate(ContinuousScheduler(), k=0.01)},
            change_notification=True,
            delta_change_notification=True,
        ),
        lambda: NSFrozenLakeWrapper(
            gym.make("FrozenLake-v1"),
            {"P": UniformDrift(RandomScheduler(0.5), rate=0.1)},
            change_notification=True,
        ),
        lambda: NSCliffWalkingWrapper(
            gym.make("CliffWalking-v1"), {"P": RandomCategorical(ContinuousScheduler())}
        ),
        lambda: NSBridgeWrapper(
            gym.make("ns_pz_compat/Bridge-v0"),
            {"P": DistributionDecrementUpdate(ContinuousScheduler(), k=0.1)},
            change_notification=True,
            delta_change_notification=True,
        ),
    ],
    ids=["cartpole", "frozen_lake", "cliff_walking", "bridge"],
)
def test_wrappers_pass_gymnasium_check_env(build):
    """D12: every wrapper passes Gymnasium's env checker (NS-Gym's fail it)."""
    quiet_check_env(build())


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: cartpole({}, foo=3), TypeError, r"unexpected keyword argument\(s\) \['foo'\]"),
        (
            lambda: cartpole({}, delta_change_notification=True),
            ValueError,
            r"delta_change_notification=True needs change_notification=True",
        ),
        (
            lambda: cartpole({"maspole": IncrementUpdate(ContinuousScheduler(), k=1)}),
            ValueError,
            r"tunable_params has 'maspole', which CartPoleEnv does not have; tunable: \[",
        ),
        (
            lambda: cartpole({"masspole": UniformDrift(ContinuousScheduler(), 0.1)}),
            TypeError,
            r"must be a scalar update function \('masspole' is a number\)",
        ),
        (
            lambda: NSFrozenLakeWrapper(
                gym.make("FrozenLake-v1"), {"P": IncrementUpdate(ContinuousScheduler(), k=1)}
            ),
            TypeError,
            r"must be a distribution update function \('P' is a probability vector\)",
        ),
        (
            lambda: cartpole({"masspole": NativeIncrement(NativeContinuous(start=0), k=1)}),
            TypeError,
            r"is a native ns_pz update function",
        ),
        (
            lambda: NSClassicControlWrapper(gym.make("FrozenLake-v1"), {}),
            ValueError,
            r"takes a classic-control env .* got an env of class FrozenLakeEnv",
        ),
        (
            lambda: NSFrozenLakeWrapper(
                gym.make("FrozenLake-v1"), {}, initial_prob_dist=[0.5, 0.2, 0.2]
            ),
            ValueError,
            r"initial_prob_dist=\[0.5, 0.2, 0.2\] sums to 0.9",
        ),
        (
            lambda: NSCliffWalkingWrapper(
                gym.make("CliffWalking-v1"), {}, initial_prob_dist=[1, 0, 0]
            ),
            ValueError,
            r"has 3 elements; NSCliffWalkingWrapper needs 4",
        ),
        (
            lambda: NSCliffWalkingWrapper(gym.make("CliffWalking-v1", is_slippery=True), {}),
            ValueError,
            r"env is slippery",
        ),
        (
            lambda: NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), {}, modified_rewards={"S": 1}),
            ValueError,
            r"modified_rewards gives 'S' 1.0 but 'F' 0.0",
        ),
        (
            lambda: NSFrozenLakeWrapper(gym.make("FrozenLake-v1"), {}, modified_rewards={"X": 1}),
            ValueError,
            r"modified_rewards has cell letters \['X'\]",
        ),
        (
            lambda: NSBridgeWrapper(gym.make("ns_pz_compat/Bridge-v0"), {}, modified_rewards={}),
            ValueError,
            r"the Bridge's rewards are fixed",
        ),
        (lambda: cartpole({}, scalar_reward="no"), TypeError, r"scalar_reward='no' must be a bool"),
        (lambda: NSClassicControlWrapper("CartPole-v1", {}), TypeError, r"must be a Gymnasium env"),
        (lambda: cartpole([1]), TypeError, r"tunable_params=\[1\] must be a dict"),
    ],
)
def test_wrapper_arguments_are_checked(build, error, match):
    """What NS-Gym asserts, or silently accepts, raises naming the argument and the rule."""
    with pytest.raises(error, match=match):
        build()


# -- the other classic-control families (built on another branch) -----------------------------
OTHER_CLASSIC = [
    ("MountainCar-v0", "ns_pz.envs.mountain_car", "gravity"),
    ("MountainCarContinuous-v0", "ns_pz.envs.mountain_car", "power"),
    ("Acrobot-v1", "ns_pz.envs.acrobot", "LINK_MASS_1"),
    ("Pendulum-v1", "ns_pz.envs.pendulum", "m"),
]


@pytest.mark.parametrize(("env_id", "module", "param"), OTHER_CLASSIC)
def test_other_classic_control_envs(env_id, module, param):
    """Each NS-Gym name maps to a θ field, θ_0 is read from the env, a schedule changes θ."""
    pytest.importorskip(module)
    env = gym.make(env_id)
    binding = CLASSIC_CONTROL[type(env.unwrapped).__name__]
    params_cls = binding.family_class().params_cls
    assert set(binding.names.values()) <= set(params_cls.names())
    wrapped = NSClassicControlWrapper(
        env,
        {param: uf.GeometricProgression(ContinuousScheduler(), r=1.01)},
        change_notification=True,
        delta_change_notification=True,
    )
    wrapped.reset(seed=0)
    for name in binding.names:
        assert wrapped.get_params()[name] == pytest.approx(float(getattr(env.unwrapped, name)))
    before = wrapped.get_params()[param]
    obs = wrapped.step(wrapped.action_space.sample())[0]
    assert wrapped.get_params()[param] == pytest.approx(before * 1.01)
    assert obs["delta_change"][param] == pytest.approx(before * 0.01)
    quiet_check_env(wrapped)


def test_a_missing_family_is_reported_clearly():
    """Without the family module, the wrapper says which ns_pz family the env needs."""
    try:
        import ns_pz.envs.pendulum  # noqa: F401
    except ModuleNotFoundError:
        with pytest.raises(ValueError, match=r"PendulumEnv needs the ns_pz family"):
            NSClassicControlWrapper(gym.make("Pendulum-v1"), {})
    else:
        pytest.skip("the pendulum family is installed")


def test_cartpole_steps_equal_gymnasium_with_the_change_applied_first():
    """NS-Gym's timing: a change fired at step t is set on the env before transition t.

    Reference: Gymnasium's own CartPole, reset with the same seed, with masspole (and the two
    quantities CartPole derives from it) set by hand before each step.
    """
    env = cartpole({"masspole": IncrementUpdate(PeriodicScheduler(2), k=0.2)})
    raw = gym.make("CartPole-v1").unwrapped
    obs, _ = env.reset(seed=7)
    raw_obs, _ = raw.reset(seed=7)
    assert np.array_equal(obs["state"], raw_obs)
    masspole = 0.1
    for t, action in enumerate([1, 0, 1, 1, 0, 0, 1, 0]):
        if t % 2 == 0:
            masspole += 0.2
            raw.masspole = masspole
            raw.total_mass = raw.masspole + raw.masscart
            raw.polemass_length = raw.masspole * raw.length
        obs, _, terminated, _, _ = env.step(action)
        raw_obs, _, raw_terminated, _, _ = raw.step(action)
        assert np.allclose(obs["state"], raw_obs, atol=1e-6) and terminated == raw_terminated


class OwnGeneratorScheduler(RandomScheduler):
    """A user subclass with its own rule (even steps only) and its own generator."""

    def __init__(self, probability, seed):
        super().__init__(probability)
        self.my_rng = np.random.default_rng(seed)

    def _check(self, t):
        return t % 2 == 0 and bool(self.my_rng.random() < self.probability)


class OwnGeneratorBase(base.Scheduler):
    """The same rule on NS-Gym's abstract Scheduler."""

    def __init__(self, probability, seed):
        super().__init__()
        self.probability = probability
        self.my_rng = np.random.default_rng(seed)

    _check = OwnGeneratorScheduler._check


def firing_steps(env, seed, steps=30):
    """Steps at which the wrapper's masspole changed in one episode."""
    env.reset(seed=seed)
    changed = []
    for t in range(steps):
        obs, _, terminated, truncated, _ = env.step(t % 2)
        if obs["env_change"]["masspole"]:
            changed.append(t)
        if terminated or truncated:
            break
    return changed


@pytest.mark.parametrize("scheduler_cls", [OwnGeneratorScheduler, OwnGeneratorBase])
def test_a_scheduler_subclass_with_its_own_generator_follows_the_reset_seed(scheduler_cls):
    """Its rule runs and its generator is reseeded from reset(seed=...) (issue 9, item 12)."""
    env = cartpole(
        {"masspole": IncrementUpdate(scheduler_cls(0.5, seed=1), k=0.01)},
        change_notification=True,
    )
    first = firing_steps(env, 3)
    assert first and all(t % 2 == 0 for t in first)
    assert first == firing_steps(env, 3)
    assert first != firing_steps(env, 4)
    env.reset(seed=3)
    assert firing_steps(env, None) != firing_steps(env, None)


# -- issue 9: NS-Gym code that reads parameters off the env --------------------------------------
READS = [
    # NS-Gym 1.0.12, IncrementUpdate(PeriodicScheduler(2), k) on the parameter: read before the
    # wrapper's reset, after reset(seed=0), after each of 4 steps, after a second reset.
    ("CartPole-v1", "gravity", 0.5, [9.8, 9.8, 10.3, 10.3, 10.8, 10.8, 9.8]),
    ("CartPole-v1", "force_mag", 0.5, [10.0, 10.0, 10.5, 10.5, 11.0, 11.0, 10.0]),
    ("Pendulum-v1", "m", 0.5, [1.0, 1.0, 1.5, 1.5, 2.0, 2.0, 1.0]),
    ("Acrobot-v1", "LINK_LENGTH_1", 0.5, [1.0, 1.0, 1.5, 1.5, 2.0, 2.0, 1.0]),
    ("MountainCar-v0", "force", 0.0005, [0.001, 0.001, 0.0015, 0.0015, 0.002, 0.002, 0.001]),
]


@pytest.mark.parametrize(("env_id", "name", "k", "nsgym"), READS)
def test_parameter_reads_show_the_theta_of_the_last_transition(env_id, name, k, nsgym):
    """env.unwrapped.X and ns_env.unwrapped.X show θ as NS-Gym's do (issue 9, item 9).

    Between steps that is the θ the last transition used: NS-Gym sets a change on the env just
    before the transition it affects, and reads after the step see it.
    """
    env = gym.make(env_id)
    ns_env = NSClassicControlWrapper(env, {name: IncrementUpdate(PeriodicScheduler(2), k=k)})
    reads = [getattr(env.unwrapped, name)]
    ns_env.reset(seed=0)
    reads.append(getattr(env.unwrapped, name))
    for _ in range(4):
        ns_env.step(ns_env.action_space.sample())
        assert getattr(ns_env.unwrapped, name) == getattr(env.unwrapped, name)
        reads.append(getattr(env.unwrapped, name))
    ns_env.reset()
    reads.append(getattr(ns_env.unwrapped, name))
    assert reads == pytest.approx(nsgym)


def test_cartpole_reads_include_the_derived_quantities():
    """NS-Gym keeps total_mass and polemass_length in step with masspole; so do the views.

    NS-Gym 1.0.12, IncrementUpdate(ContinuousScheduler(), k=0.1) on masspole, after steps 1-3:
    (masspole, total_mass, polemass_length) = (0.2, 1.2, 0.1), (0.3, 1.3, 0.15), (0.4, 1.4, 0.2).
    """
    env = gym.make("CartPole-v1")
    ns_env = NSClassicControlWrapper(env, {"masspole": IncrementUpdate(ContinuousScheduler(), 0.1)})
    ns_env.reset(seed=0)
    for expected in [(0.2, 1.2, 0.1), (0.3, 1.3, 0.15), (0.4, 1.4, 0.2)]:
        ns_env.step(0)
        for owner in (env.unwrapped, ns_env.unwrapped):
            read = (owner.masspole, owner.total_mass, owner.polemass_length)
            assert read == pytest.approx(expected)
    # A planning env reads its own θ: the initial one here (no delta notification), as NS-Gym.
    planning = ns_env.get_planning_env()
    assert planning.unwrapped.masspole == 0.1 and env.unwrapped.masspole == pytest.approx(0.4)
    planning.step(0)
    assert planning.unwrapped.masspole == 0.1 and env.unwrapped.masspole == pytest.approx(0.4)


def test_stepping_the_wrapped_env_by_hand_uses_the_current_theta():
    """The env passed is the one that changes, as in NS-Gym: its own step sees the new θ."""
    env = gym.make("CartPole-v1")
    ns_env = NSClassicControlWrapper(env, {"masspole": IncrementUpdate(ContinuousScheduler(), 0.5)})
    ns_env.reset(seed=0)
    ns_env.step(0)
    reference = gym.make("CartPole-v1").unwrapped
    reference.masspole = 0.6
    reference.total_mass, reference.polemass_length = 1.6, 0.3
    for raw in (env.unwrapped, reference):
        raw.reset(seed=5)
    assert np.array_equal(env.unwrapped.step(1)[0], reference.step(1)[0])


def test_a_random_walk_matches_nsgym_and_its_own_seed():
    """RandomWalk on gravity: NS-Gym's numbers for reset(seed=1); seed= alone reproduces a run.

    NS-Gym 1.0.12 reseeds a wrapper's only update function from SeedSequence(1)'s first child,
    which is the generator ns_pz's nature draws from, so after reset(seed=1) both read gravity
    9.159681471601335, 9.552454187001999, 9.159301803295117 after steps 1-3. Without a reset
    seed, NS-Gym's walk follows RandomWalk's own seed=: the same in every run, different in
    every episode.
    """

    def walks(env, seeds):
        out = []
        for seed in seeds:
            env.reset(seed=seed)
            out.append([env.step(0)[0] is not None and env.unwrapped.gravity for _ in range(3)])
        return out

    def build():
        return NSClassicControlWrapper(
            gym.make("CartPole-v1"), {"gravity": RandomWalk(ContinuousScheduler(), seed=5)}
        )

    assert walks(build(), [1]) == [[9.159681471601335, 9.552454187001999, 9.159301803295117]]
    unseeded = walks(build(), [None, None, None])
    assert unseeded == walks(build(), [None, None, None])
    assert unseeded[0] != unseeded[1] != unseeded[2]
    assert (
        unseeded[0]
        != walks(
            NSClassicControlWrapper(
                gym.make("CartPole-v1"), {"gravity": RandomWalk(ContinuousScheduler(), seed=6)}
            ),
            [None],
        )[0]
    )


@pytest.mark.parametrize(
    ("env_id", "name", "native"),
    [("CartPole-v1", "masspole", "masspole"), ("Pendulum-v1", "m", "mass")],
)
def test_writes_that_bypass_nature_are_refused_with_the_way_to_do_it(env_id, name, native):
    """env.unwrapped.X = v and ns_env.unwrapped.X = v raise, pointing to set_params."""
    env = gym.make(env_id)
    ns_env = NSClassicControlWrapper(env, {})
    for owner in (env.unwrapped, ns_env.unwrapped):
        with pytest.raises(AttributeError, match=rf"{name} is read-only.*set_params\({native}="):
            setattr(owner, name, 0.5)
    ns_env.reset(seed=0)
    ns_env.unwrapped.set_params(**{native: 0.5})
    ns_env.step(ns_env.action_space.sample())  # reads show θ once a transition has used it
    assert getattr(env.unwrapped, name) == 0.5
    assert isinstance(copy.deepcopy(env.unwrapped), type(env.unwrapped).__mro__[1])
    snapshot = copy.deepcopy(env.unwrapped)
    ns_env.reset(seed=0)
    assert getattr(snapshot, name) == 0.5 and getattr(env.unwrapped, name) != 0.5
    setattr(snapshot, name, 0.7)  # a copy is a plain env again
    ns_env.unwrapped.set_params(**{native: 0.5})
    ns_env.step(ns_env.action_space.sample())
    revived = pickle.loads(pickle.dumps(ns_env))
    assert getattr(revived.base_env.unwrapped, name) == 0.5
    revived.unwrapped.set_params(**{native: 0.6})
    revived.step(revived.action_space.sample())
    assert getattr(revived.base_env.unwrapped, name) == 0.6 and getattr(env.unwrapped, name) == 0.5


def test_grid_reads_transition_prob_and_tables():
    """transition_prob and the tables P[s][a] follow the slip, as NS-Gym's.

    NS-Gym 1.0.12, DistributionDecrementUpdate(PeriodicScheduler(2), k=0.25) from [1, 0, 0, 0],
    CliffWalking-v1, after steps 1-3: transition_prob [0.75, 1/12, 1/12, 1/12] twice, then
    [0.5, 1/6, 1/6, 1/6]; env.unwrapped.P[5][1] (and ns_env.unwrapped.P, ns_env.P) then
    [(0.75, 6, -1, False), (1/12, 17, -1, False), (1/12, 5, -1, False), (1/12, 4, -1, False)].
    """
    env = gym.make("CliffWalking-v1")
    ns_env = NSCliffWalkingWrapper(
        env,
        {"P": DistributionDecrementUpdate(PeriodicScheduler(2), k=0.25)},
        initial_prob_dist=[1.0, 0.0, 0.0, 0.0],
    )
    ns_env.reset(seed=0)
    assert env.unwrapped.P[5][1][0] == (1.0, 6, -1.0, False)
    slips = []
    for _ in range(3):
        ns_env.step(1)
        slips.append(ns_env.transition_prob)
        assert env.unwrapped.P[5][1] == ns_env.unwrapped.P[5][1] == ns_env.P[5][1]
    expected = [[0.75] + [1 / 12] * 3] * 2 + [[0.5] + [1 / 6] * 3]
    assert np.allclose(slips, expected, rtol=0, atol=1e-12)
    entries = env.unwrapped.P[5][1]
    assert [entry[1:] for entry in entries] == [
        (6, -1, False),
        (17, -1, False),
        (5, -1, False),
        (4, -1, False),
    ]
    assert np.allclose([entry[0] for entry in entries], [0.5, 1 / 6, 1 / 6, 1 / 6], atol=1e-12)
    lake = gym.make("FrozenLake-v1")
    NSFrozenLakeWrapper(lake, {}).reset(seed=0)
    assert lake.unwrapped.P[5][1] == ((1.0, 5, 0.0, True),)  # a hole: NS-Gym's single entry
    with pytest.raises(AttributeError, match=r"P is read-only.*set_params\(slip="):
        lake.unwrapped.P = {}


def test_nsgym_module_paths_import():
    """NS-Gym's submodules exist under ns_pz.compat with its names; unsupported ones say so."""
    import importlib

    expected = {
        "wrappers.classic_control": ["NSClassicControlWrapper"],
        "wrappers.toy_text": ["NSFrozenLakeWrapper", "NSCliffWalkingWrapper", "NSBridgeWrapper"],
        "envs.Bridge": ["Bridge"],
        "envs": ["Bridge"],
        "base": ["NSWrapper", "Scheduler", "UpdateFn", "UpdateDistributionFn", "Reward"],
        "update_functions.single_param": ["IncrementUpdate", "RandomWalk"],
        "update_functions.distribution": ["DistributionDecrementUpdate"],
        "schedulers": ["ContinuousScheduler", "RandomScheduler"],
    }
    for module, names in expected.items():
        loaded = importlib.import_module(f"ns_pz.compat.{module}")
        for name in names:
            assert getattr(loaded, name) is not None
    from ns_pz.compat.base import NSWrapper

    assert NSWrapper is wrappers.NSWrapper
    for module in ("box_2d", "purtsuit_evasion_wrapper"):
        with pytest.raises(ImportError, match="ns_pz has no .* family"):
            importlib.import_module(f"ns_pz.compat.wrappers.{module}")
    with pytest.raises(ImportError, match="no NSBox2dWrapper"):
        from ns_pz.compat.wrappers import NSBox2dWrapper  # noqa: F401


# -- issue 9, item 11: the settings of the env you wrap ------------------------------------------
def tweak(env_id, name, value, **make_kwargs):
    """gym.make(env_id) with one attribute of its core set by hand."""
    env = gym.make(env_id, **make_kwargs)
    setattr(env.unwrapped, name, value)
    return env


REFUSED = [
    (lambda: gym.make("CartPole-v1", sutton_barto_reward=True), "sutton_barto_reward=True"),
    (lambda: tweak("CartPole-v1", "x_threshold", 3.0), "x_threshold=3.0"),
    (lambda: tweak("CartPole-v1", "theta_threshold_radians", 0.5), "theta_threshold_radians"),
    (lambda: tweak("MountainCar-v0", "max_speed", 0.1), "max_speed=0.1"),
    (lambda: tweak("Pendulum-v1", "max_torque", 3.0), "max_torque=3.0"),
    (lambda: tweak("Acrobot-v1", "book_or_nips", "nips"), "book_or_nips='nips'"),
    (lambda: tweak("Acrobot-v1", "MAX_VEL_1", 1.0), "MAX_VEL_1=1.0"),
    (lambda: gym.make("CartPole-v1", render_mode="rgb_array"), "render_mode='rgb_array'"),
    (
        lambda: gym.wrappers.TransformReward(gym.make("CartPole-v1"), lambda r: 2 * r),
        "wrapped in TransformReward",
    ),
    (
        lambda: gym.wrappers.RecordEpisodeStatistics(gym.make("CartPole-v1")),
        "wrapped in RecordEpisodeStatistics",
    ),
]


@pytest.mark.parametrize(("build", "match"), REFUSED)
def test_settings_the_wrapper_cannot_honour_are_refused(build, match):
    """Never a different task than the one built: the setting is named (issue 9, item 11)."""
    with pytest.raises(ValueError, match=re.escape(match) if "(" in match else match):
        NSClassicControlWrapper(build(), {})


def test_settings_the_wrapper_honours():
    """goal_velocity, Pendulum's g, torque noise and FrozenLake's reward_schedule reach θ."""
    car = NSClassicControlWrapper(gym.make("MountainCar-v0", goal_velocity=0.02), {})
    assert car.core.family.goal_velocity == 0.02
    pendulum = NSClassicControlWrapper(gym.make("Pendulum-v1", g=5.0), {})
    assert pendulum.get_params()["g"] == 5.0
    acrobot = NSClassicControlWrapper(tweak("Acrobot-v1", "torque_noise_max", 0.1), {})
    assert acrobot.core.family.torque_noise_max == 0.1
    lake = NSFrozenLakeWrapper(gym.make("FrozenLake-v1", reward_schedule=(10, -1, 0)), {})
    assert lake.P[14][2] == ((1.0, 15, 10.0, True), (0.0, 10, 0.0, False), (0.0, 14, 0.0, False))
    assert lake.P[4][1][0] == (1.0, 8, 0.0, False) and lake.P[0][1][0][2] == 0.0
    assert lake.P[1][1][0] == (1.0, 5, -1.0, True)
    modified = NSFrozenLakeWrapper(
        gym.make("FrozenLake-v1", reward_schedule=(10, -1, 0)), {}, modified_rewards={"G": 2}
    )
    assert modified.P[14][2][0] == (1.0, 15, 2.0, True) and modified.P[1][1][0][2] == -1.0
    # As in NS-Gym, the slip comes from initial_prob_dist, not from is_slippery.
    slippery = NSFrozenLakeWrapper(gym.make("FrozenLake-v1", is_slippery=True), {})
    assert slippery.transition_prob == [1.0, 0.0, 0.0]


# -- issue 9, item 12: the Bridge's slip attributes --------------------------------------------
def test_bridge_slip_attributes_take_effect():
    """e.P = [...] changes the Bridge's dynamics; a bad vector raises (NS-Gym's is ignored)."""
    first_moves = {}
    for slip in ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]):
        bridge = gym.make("ns_pz_compat/Bridge-v0")
        bridge.unwrapped.P = slip
        bridge.reset(seed=0)
        first_moves[tuple(slip)] = bridge.step(0)[0]  # LEFT; slipping turns it into DOWN
    assert first_moves == {(1.0, 0.0, 0.0): 2 * 8 + 3, (0.0, 1.0, 0.0): 3 * 8 + 4}
    bridge = gym.make("ns_pz_compat/Bridge-v0").unwrapped
    with pytest.raises(ValueError, match=r"P=\[0.5, 0.2, 0.2\] sums to 0.9"):
        bridge.P = [0.5, 0.2, 0.2]
    with pytest.raises(AttributeError, match="split_probs=False.*not P_left"):
        bridge.P_left = [1.0, 0.0, 0.0]
    bridge.P = [0.4, 0.3, 0.3]
    assert bridge.transition_matrix[20][0][0] == (0.4, 19, 0.0, False)
    wrapped = NSBridgeWrapper(bridge, {})
    assert wrapped.get_params() == {"P": [0.4, 0.3, 0.3]}  # the env's own P is θ_0
    with pytest.raises(AttributeError, match="read-only"):
        bridge.P = [1.0, 0.0, 0.0]


def test_bridge_split_mode_follows_the_tunable_names_as_in_nsgym():
    """{"P_left": fn} on a plain Bridge switches it to split mode; (left, right) start apart."""
    bridge = gym.make("ns_pz_compat/Bridge-v0")
    wrapped = NSBridgeWrapper(
        bridge,
        {"P_left": DistributionDecrementUpdate(ContinuousScheduler(), k=0.1)},
        initial_prob_dist=([1.0, 0.0, 0.0], [0.5, 0.25, 0.25]),
    )
    assert bridge.unwrapped.split_probs
    wrapped.reset(seed=0)
    wrapped.step(3)
    params = wrapped.get_params()
    assert params["P_left"] == pytest.approx([0.9, 0.05, 0.05])
    assert params["P_right"] == [0.5, 0.25, 0.25]
    assert bridge.unwrapped.P_right == [0.5, 0.25, 0.25]


# -- issue 27, item 5: NS-Gym code that reads the base env through ``unwrapped`` ----------------
BASE_ENVS = {
    "CartPole-v1": ("masspole", lambda: IncrementUpdate(ContinuousScheduler(), k=0.01)),
    "Acrobot-v1": ("LINK_MASS_1", lambda: IncrementUpdate(ContinuousScheduler(), k=0.01)),
    "MountainCar-v0": ("gravity", lambda: IncrementUpdate(ContinuousScheduler(), k=1e-5)),
    "Pendulum-v1": ("m", lambda: IncrementUpdate(ContinuousScheduler(), k=0.01)),
    "FrozenLake-v1": ("P", lambda: DistributionDecrementUpdate(ContinuousScheduler(), k=0.01)),
    "CliffWalking-v1": ("P", lambda: DistributionDecrementUpdate(ContinuousScheduler(), k=0.01)),
}


def _wrap(gym_id):
    env = gym.make(gym_id)
    name, fn = BASE_ENVS[gym_id]
    wrapper = {"FrozenLake-v1": NSFrozenLakeWrapper, "CliffWalking-v1": NSCliffWalkingWrapper}
    return env, wrapper.get(gym_id, NSClassicControlWrapper)(env, {name: fn()})


@pytest.mark.parametrize("gym_id", sorted(BASE_ENVS))
def test_unwrapped_is_named_and_shaped_like_the_base_env(gym_id):
    """NS-Gym code that reads the base env through ``ns_env.unwrapped`` runs.

    TUNABLE_PARAMS[type(ns_env.unwrapped).__name__] raised KeyError: 'CompatCore', and
    ns_env.unwrapped.observation_space was compat's Dict, not the base env's space.
    """
    env, ns_env = _wrap(gym_id)
    name = type(env.unwrapped).__name__
    assert type(ns_env.unwrapped).__name__ == name
    assert base.TUNABLE_PARAMS[type(ns_env.unwrapped).__name__] == ns_env.get_default_params()
    assert ns_env.unwrapped.observation_space == env.unwrapped.observation_space
    state, _ = ns_env.unwrapped.reset(seed=3)
    assert ns_env.unwrapped.observation_space.contains(state)
    observation, _ = ns_env.reset(seed=3)
    assert np.array_equal(observation["state"], state)
    action = ns_env.action_space.sample() if gym_id == "Pendulum-v1" else 0
    assert ns_env.unwrapped.observation_space.contains(ns_env.unwrapped.step(action)[0])
    revived = pickle.loads(pickle.dumps(ns_env))  # the renamed class pickles and copies
    assert type(revived.unwrapped).__name__ == name
    assert type(copy.deepcopy(ns_env).unwrapped).__name__ == name
    assert isinstance(ns_env.unwrapped, ns_pz.compat.attributes.CompatCore)


def test_distribution_update_functions_are_update_functions_as_in_nsgym():
    """isinstance(fn, UpdateFn) was False for every distribution update function."""
    for name in uf.distribution.__all__:
        cls = getattr(uf.distribution, name)
        assert issubclass(cls, base.UpdateFn) and issubclass(cls, base.UpdateDistributionFn)
    for name in uf.single_param.__all__:
        assert not issubclass(getattr(uf.single_param, name), base.UpdateDistributionFn)
    drift = UniformDrift(ContinuousScheduler(), 0.1)
    assert isinstance(drift, base.UpdateFn)
    with pytest.raises(TypeError, match="must be a scalar update function"):
        cartpole({"masspole": drift})  # still refused where a number changes


def _schedule(scheduler_seed, reset_seed, episodes=2):
    fn = IncrementUpdate(MemorylessScheduler(0.3, seed=scheduler_seed), k=1e-5)
    env = NSClassicControlWrapper(gym.make("MountainCar-v0"), {"gravity": fn})
    runs = []
    for _ in range(episodes):
        observation, _ = env.reset(seed=reset_seed)
        changes = []
        for t in range(40):
            info = env.step(1)[-1]
            if info["Ground Truth Env Change"]["gravity"]:
                changes.append(t)
        runs.append((observation["state"].tolist(), changes))
    return runs


def test_a_seeded_memoryless_scheduler_differs_between_seeds_under_one_reset_seed():
    """MemorylessScheduler(seed=1) and seed=2 gave one schedule once reset had a seed."""
    one, two = _schedule(1, 0), _schedule(2, 0)
    assert one == _schedule(1, 0)  # the same pair repeats
    assert one[0][0] == two[0][0]  # the env's start follows the reset seed alone
    assert one[0][1] != two[0][1]  # the schedule follows the scheduler's seed too
    unseeded = _schedule(1, None), _schedule(2, None)
    assert unseeded[0] == _schedule(1, None) and unseeded[0] != unseeded[1]


def test_bridge_per_region_api_of_nsgyms_current_release():
    """left_side_prob / right_side_prob and get_loc_based_prob (and its first spelling)."""
    from ns_pz.compat.envs.Bridge import Bridge

    bridge = Bridge(split_probs=True)
    bridge.left_side_prob = [0.8, 0.1, 0.1]
    assert bridge.P_left == bridge.left_side_prob == [0.8, 0.1, 0.1]
    assert bridge.right_side_prob == bridge.P_right == [1.0, 0.0, 0.0]
    assert bridge.get_loc_based_prob((2, 3)) == [0.8, 0.1, 0.1]  # col < ncol // 2: left
    assert bridge.get_loc_basedProb(np.array([2, 4])) == [1.0, 0.0, 0.0]
    assert Bridge(global_init_probs=[0.5, 0.25, 0.25]).get_loc_based_prob((2, 1)) == [
        0.5,
        0.25,
        0.25,
    ]
    for bad in ((9, 0), (2, 8), (2,), (2, 1.5), "ab"):
        with pytest.raises(ValueError, match=r"must be a \(row, col\) pair of integers"):
            bridge.get_loc_based_prob(bad)
    env = Bridge()
    ns_env = NSBridgeWrapper(
        env, {"P_left": DistributionDecrementUpdate(ContinuousScheduler(), k=0.1)}
    )
    ns_env.reset(seed=0)
    ns_env.step(0)
    left = ns_env.get_params()["P_left"]
    for owner in (env, ns_env.unwrapped):
        assert owner.left_side_prob == owner.P_left == left
        assert owner.right_side_prob == [1.0, 0.0, 0.0]
        assert owner.get_loc_based_prob((2, 1)) == left
        assert owner.get_loc_basedProb((2, 6)) == [1.0, 0.0, 0.0]
        with pytest.raises(AttributeError, match="read-only"):
            owner.left_side_prob = [1.0, 0.0, 0.0]
