"""The Gymnasium view: timing of changes and notifications, levels, planning envs, bad input."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from ns_pz.envs.cartpole import CartPoleFamily, CartPoleParams

import ns_pz
from ns_pz import ParamOutOfRange, ResetNeeded, UnknownParam
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    IncrementUpdate,
    RandomNature,
    ScriptedNature,
    StepWiseUpdate,
)

MASSPOLE = CartPoleParams.names().index("masspole")


def single_change(level: str) -> ns_pz.NSGymEnv:
    """CartPole whose masspole jumps 0.1 -> 0.5 at step 1 ("after the first decision epoch")."""
    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({1}), [0.5])})
    return ns_pz.make_gym("ns_pz/CartPole-v0", nature=nature, notification=level)


def test_change_at_step_1_affects_transition_1_and_is_heard_after_it():
    """θ_1 drives the second transition; the agent is told in the observation that follows it."""
    env = single_change("detailed")
    obs, _ = env.reset(seed=0)
    assert obs["relative_time"][0] == 0 and not obs["env_change"].any()
    state0 = env._process.state
    obs, *_ = env.step(1)  # transition 0 under θ_0
    assert env._process.state == CartPoleFamily().step(state0, 1, CartPoleParams(), None)[0]
    # Nature has already chosen θ_1 (its turn of step 1 follows transition 0); unheard of yet.
    assert not obs["env_change"].any() and env.ground_truth().change_times == (1,)
    state1 = env._process.state
    obs, *_ = env.step(0)  # transition 1 under θ_1
    expected = CartPoleFamily().step(state1, 0, CartPoleParams(masspole=0.5), None)[0]
    assert env._process.state == expected
    assert obs["relative_time"][0] == 2
    assert obs["env_change"].tolist() == [0, 0, 1, 0, 0, 0]
    assert obs["delta_change"][MASSPOLE] == pytest.approx(0.4)
    assert env.ground_truth().change_times == (1,)
    obs, *_ = env.step(0)
    assert not obs["env_change"].any() and not obs["delta_change"].any()


@pytest.mark.parametrize(
    ("level", "flags", "size"),
    [
        ("none", [0] * 6, 0.0),
        ("basic", [0, 0, 1, 0, 0, 0], 0.0),
        ("detailed", [0, 0, 1, 0, 0, 0], 0.4),
    ],
)
def test_levels_fill_only_their_fields_and_never_change_the_space(level, flags, size):
    """none: nothing; basic: flags; detailed: flags and sizes. The space stays the same."""
    env = single_change(level)
    env.reset(seed=0)
    env.step(0)
    obs, *_ = env.step(0)
    assert obs["env_change"].tolist() == flags
    assert obs["delta_change"][MASSPOLE] == pytest.approx(size)
    assert env.observation_space == single_change("none").observation_space
    assert obs in env.observation_space


@pytest.mark.parametrize(("level", "expected"), [("none", 0.1), ("basic", 0.1), ("detailed", 0.5)])
def test_planning_env_holds_theta0_or_current_theta(level, expected):
    """get_planning_env(): θ_0 at none/basic, the current θ at detailed, at the current state."""
    env = single_change(level)
    env.reset(seed=0)
    env.step(0)
    env.step(0)
    planning = env.get_planning_env()
    assert planning.ground_truth().theta.masspole == expected
    assert planning._process.state == env._process.state
    assert planning.planning_model().theta.masspole == expected
    assert env.planning_model().get_state() == env._process.state


def test_planning_env_is_stationary_and_independent():
    """Nature is frozen in the planning env, and stepping it leaves the real env untouched."""
    nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=0), k=0.1)})
    env = ns_pz.make_gym("ns_pz/CartPole-v0", nature=nature, notification="detailed")
    env.reset(seed=1)
    env.step(0)
    before = env._process.state
    planning = env.get_planning_env()
    theta = planning.ground_truth().theta
    for _ in range(5):
        obs, *_ = planning.step(1)
        assert not obs["env_change"].any()
    assert planning.ground_truth().theta == theta
    assert env._process.state == before
    assert isinstance(planning, gym.Env)


def test_planning_envs_are_reproducible_from_the_seed():
    """Two runs with one seed hand out planning envs that sample the same futures."""

    def futures(seed: int) -> list:
        nature = ScriptedNature(
            {"slip": DistributionDecrementUpdate(ContinuousScheduler(start=0), k=0.1)}
        )
        env = ns_pz.make_gym("ns_pz/FrozenLake-v0", nature=nature, notification="detailed")
        env.reset(seed=seed)
        planning = env.get_planning_env()
        states, done = [], False
        while not done:
            obs, _, terminated, truncated, _ = planning.step(1)
            states.append(obs["state"])
            done = terminated or truncated
        return states

    assert futures(5) == futures(5)
    assert len({tuple(futures(seed)) for seed in range(6)}) > 1


def test_using_a_planning_env_leaves_the_real_env_streams_alone():
    """Planning inside a planning twin changes neither the real env's planning draws nor its own."""

    def real_draws(use_twin: bool) -> list:
        env = ns_pz.make_gym("ns_pz/FrozenLake-v0", notification="detailed")
        env.reset(seed=4)
        twin = env.get_planning_env()
        assert twin._process.monitor_rng is not env._process.monitor_rng
        if use_twin:
            twin.planning_model()
            twin.get_planning_env()
            twin.step(1)
        model = env.planning_model()
        return [model.transition(0, 2)[0] for _ in range(12)] + [env.step(1)[0]["state"]]

    assert real_draws(False) == real_draws(True)


def test_bad_calls_raise_before_anything_changes():
    """Planning, stepping or changing θ without a running episode raise ResetNeeded."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    with pytest.raises(
        ResetNeeded, match="get_planning_env\\(\\) or branch\\(\\) called before reset"
    ):
        env.get_planning_env()
    with pytest.raises(ResetNeeded, match="before reset"):
        env.planning_model()
    with pytest.raises(ResetNeeded, match="step\\(\\) called before reset"):
        env.step(0)
    assert not env._process.started
    env.reset(seed=0, options=None)
    env.set_params(slip=(1.0, 0.0, 0.0))
    for _ in range(3):  # DOWN three times from the start, without slipping: the hole at (3, 0)
        *_, terminated, _, _ = env.step(1)
    assert terminated
    t, state, truth = env._process.t, env._process.state, env.ground_truth()
    with pytest.raises(ResetNeeded, match="after the episode ended"):
        env.step(0)
    with pytest.raises(ResetNeeded, match="set_params\\(\\) called after the episode ended"):
        env.set_params(slip=(0.5, 0.25, 0.25))
    assert (env._process.t, env._process.state, env.ground_truth()) == (t, state, truth)


@pytest.mark.parametrize("action", [4, -1, 1.5, "left", None, np.array([1, 2]), True])
def test_actions_outside_the_space_are_refused(action):
    """An action outside the action space raises ValueError naming it; nothing moves."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="is outside the action space Discrete\\(4\\)"):
        env.step(action)
    assert env._process.t == 0
    env.step(np.int64(2))  # numpy integers are fine


def test_int_actions_are_checked_against_the_family_s_current_action_space():
    """The ints a Discrete space holds (with its start) follow a space replaced after use."""
    from gymnasium import spaces

    family = ns_pz.make_gym("ns_pz/FrozenLake-v0").family
    assert family.check_action(3) == 3
    family.action_space = spaces.Discrete(2, start=5)
    assert family.check_action(6) == 6 and family.check_action(np.int64(5)) == 5
    for bad in (3, 4, 7):
        with pytest.raises(ValueError, match=rf"action={bad} is outside the action space"):
            family.check_action(bad)


def test_set_params_validates_strictly():
    """set_params refuses invalid values and unknown names, leaving θ as it was."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    with pytest.raises(ParamOutOfRange, match="masspole=-1.0 is outside"):
        env.set_params(masspole=-1.0)
    with pytest.raises(UnknownParam):
        env.set_params(mass=1.0)
    assert env.ground_truth().theta == CartPoleParams()


def test_info_has_no_ground_truth_unless_asked():
    """Info is {} by default; ground_truth_info=True adds the θ in force."""
    env = single_change("none")
    _, info = env.reset(seed=0)
    assert info == {} and env.step(0)[4] == {}
    env = ns_pz.make_gym("ns_pz/CartPole-v0", ground_truth_info=True)
    _, info = env.reset(seed=0)
    assert info["theta"]["masspole"] == 0.1


def test_same_seed_same_everything_and_unseeded_reset_continues():
    """reset(seed) reproduces the episode; reset() without a seed continues the streams."""

    def episodes(env: gym.Env) -> list:
        out = []
        obs, _ = env.reset(seed=3)
        for _ in range(3):
            done = False
            while not done:
                obs, reward, terminated, truncated, _ = env.step(1)
                out.append((obs["state"], reward, obs["delta_change"].tolist()))
                done = terminated or truncated
            env.reset()
        return out

    nature = ScriptedNature(
        {"slip": DistributionDecrementUpdate(ContinuousScheduler(start=0), k=0.05)}
    )
    make = lambda: ns_pz.make_gym("ns_pz/FrozenLake-v0", nature=nature, notification="detailed")  # noqa: E731
    first, second = episodes(make()), episodes(make())
    assert first == second

    env = make()
    env.reset(seed=3)
    seeded = env.np_random.bit_generator.state, env._process.nature_rng.bit_generator.state
    env.step(1)
    env.reset()  # no seed: the streams go on rather than replay seed 3
    assert env.np_random.bit_generator.state != seeded[0]
    env.reset(seed=3)
    assert env.np_random.bit_generator.state == seeded[0]
    assert env._process.nature_rng.bit_generator.state == seeded[1]


def test_gymnasium_make_applies_its_time_limit_and_kwargs():
    """gymnasium.make: registered time limit, overridable; family and NS arguments pass through."""
    env = gym.make("ns_pz/FrozenLake8x8-v0", notification="basic")
    assert env.spec.max_episode_steps == 200
    assert env.unwrapped.family.observation_space.n == 64
    assert env.unwrapped.notification_level == "basic"
    env = gym.make("ns_pz/CartPole-v0", max_episode_steps=3)
    env.reset(seed=0)
    truncated = [env.step(0 if i % 2 else 1)[3] for i in range(3)]
    assert truncated == [False, False, True]


def test_own_time_limit_truncates():
    """make_gym truncates by itself at max_episode_steps."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0", max_episode_steps=2)
    env.reset(seed=0)
    assert env.step(0)[3] is False and env.step(1)[3] is True


@pytest.mark.parametrize("keep_nature", [False, True])
def test_stepping_the_real_env_leaves_its_copies_alone(keep_nature):
    """A copy's generators, nature memory and budget spent are its own.

    The original's later steps change nothing in what the copy does.
    """
    from ns_pz.nature import NatureConstraints, RandomScheduler, RandomWalk

    def branch_run(step_original: bool) -> tuple:
        nature = ScriptedNature(
            {"masspole": RandomWalk(RandomScheduler(probability=0.7, start=0), sigma=0.05)}
        )
        env = ns_pz.make_gym(
            "ns_pz/CartPole-v0",
            nature=nature,
            notification="detailed",
            constraints=NatureConstraints(lipschitz=0.04, budget={"masspole": 0.3}),
        )
        env.reset(seed=2)
        for _ in range(3):
            env.step(1)
        twin = env.branch(keep_nature=keep_nature)
        spent = dict(twin.process.spent)
        if step_original:
            for action in (0, 1, 0, 1, 1, 0):
                env.step(action)
            assert env.process.spent != spent or not keep_nature
        assert twin.process.spent == spent
        trace = [twin.step(a)[0]["state"].tolist() for a in (0, 1, 1, 0, 1)]
        return trace, twin.ground_truth(), dict(twin.process.spent)

    assert branch_run(False) == branch_run(True)


@pytest.mark.parametrize("level", ["basic", "detailed"])
@pytest.mark.parametrize(
    "nature",
    [
        ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=0), k=0.01)}),
        RandomNature(scale=0.05),  # every parameter at once
        ScriptedNature(  # two at once, one of them on some steps only
            {
                "masspole": IncrementUpdate(ContinuousScheduler(start=0), k=0.01),
                "gravity": IncrementUpdate(DiscreteScheduler({2, 3, 7}), k=-0.5),
            }
        ),
    ],
    ids=["one parameter", "all parameters", "two parameters"],
)
def test_the_oracle_notification_is_the_true_change_of_the_last_transition(
    level: str, nature: object
) -> None:
    """Flags and sizes match θ's change behind each transition, one or many parameters."""
    env = ns_pz.NSGymEnv(CartPoleFamily(), nature=nature, notification=level)
    env.reset(seed=3)
    previous = env.ground_truth().theta0
    for _ in range(12):
        obs, _, terminated, truncated, _ = env.step(0)
        if terminated or truncated:
            break
        ran_under = env.process.last_theta
        sizes = ran_under.change_sizes(previous)
        assert obs["env_change"].tolist() == [1 if s > 0 else 0 for s in sizes]
        shown = np.asarray(sizes, np.float32) if level == "detailed" else np.zeros(len(sizes))
        assert obs["delta_change"].tolist() == shown.tolist()
        previous = ran_under


def test_view_flags_and_branches_are_checked_and_numpy_seeds_accepted():
    """Truthy strings are no flags; a branch takes this family's θ; np.int64 seeds like ints."""
    with pytest.raises(TypeError, match="ground_truth_info='no'"):
        gym.make("ns_pz/CartPole-v0", ground_truth_info="no")
    env = gym.make("ns_pz/CartPole-v0").unwrapped
    first, _ = env.reset(seed=np.int64(3))
    again, _ = env.reset(seed=3)
    np.testing.assert_array_equal(first["state"], again["state"])
    with pytest.raises(TypeError, match="must be a CartPoleParams"):
        env.branch(theta={"masspole": 0.5})
    with pytest.raises(TypeError, match="keep_nature='no'"):
        env.branch(keep_nature="no")
    with pytest.raises(ValueError, match="retake_turn=True needs keep_nature=True"):
        env.branch(retake_turn=True)
    twin = env.branch(theta=env.base_params.replace(masspole=0.5))
    assert twin.process.theta.masspole == 0.5


def test_a_change_taken_back_in_the_same_step_is_no_change():
    """set_params there and back before a transition: no change time, no notification.

    The ground truth kept a phantom change, which scoring counted as missed.
    """
    env = ns_pz.make_gym("ns_pz/CartPole-v0", notification="detailed")
    env.reset(seed=0)
    env.set_params(masspole=0.5)
    env.set_params(masspole=0.1)
    obs, *_ = env.step(0)
    truth = env.ground_truth()
    assert truth.change_times == () and truth.theta is env.process.theta0
    assert not obs["env_change"].any() and env.process.last_change is None
    env.set_params(masspole=0.5)  # a real one still counts
    env.step(0)
    assert env.ground_truth().change_times == (1,)


def test_nature_s_change_taken_back_by_hand_is_no_change_but_stays_charged():
    """Back from nature's change in the same step: no change time; nature's budget spent."""
    from ns_pz.nature import DiscreteScheduler, NatureConstraints, ScriptedNature, StepWiseUpdate

    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler([1]), [0.3])})
    env = ns_pz.make_gym(
        "ns_pz/CartPole-v0",
        nature=nature,
        constraints=NatureConstraints(budget=1.0),
        notification="detailed",
    )
    env.reset(seed=0)
    env.step(0)  # nature has moved for step 1 when it returns
    assert env.process.theta.masspole == 0.3
    env.set_params(masspole=0.1)
    obs, *_ = env.step(0)
    assert env.ground_truth().change_times == () and not obs["env_change"].any()
    assert env.process.spent == {"masspole": pytest.approx(0.2)}


def test_an_unknown_reset_option_is_reported_at_the_callers_line():
    """From the view, a gym.make stack, the game and the vector env.

    It named a line one or two frames off, in Gymnasium or Python's own code.
    """
    import warnings

    import gymnasium

    for env in (
        ns_pz.make_gym("ns_pz/CartPole-v0"),
        gymnasium.make("ns_pz/CartPole-v0"),
        ns_pz.make("ns_pz/CartPole-v0"),
        ns_pz.make_vec("ns_pz/CartPole-v0", 2),
    ):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            env.reset(seed=0, options={"foo": 1})
        assert [w.filename for w in caught] == [__file__], env
