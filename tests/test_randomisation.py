"""Domain randomisation: nature's hidden draw of θ_0, the distributions, θ sets and splits."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ns_pz
from ns_pz.errors import UnknownParam
from ns_pz.nature import (
    Choice,
    ContinuousScheduler,
    Dirichlet,
    DomainRandomisation,
    IncrementUpdate,
    LogUniform,
    Normal,
    ScriptedNature,
    ThetaSet,
    Uniform,
)

CARTPOLE = "ns_pz/CartPole-v0"
BOX = {"length": Uniform(0.3, 1.5), "masspole": LogUniform(0.05, 0.5)}


def drawn(env, seed):
    """The θ_0 an episode of ``env`` started from seed ``seed`` runs under."""
    env.reset(seed=seed)
    return env.unwrapped.ground_truth().theta0


def test_each_reset_draws_theta0_from_its_seed():
    """One seed, one draw (the same in a new env); other seeds differ; every draw in the box."""
    env = gym.make(CARTPOLE, nature=DomainRandomisation(BOX))
    first = [drawn(env, seed) for seed in range(20)]
    again = gym.make(CARTPOLE, nature=DomainRandomisation(BOX))
    assert [drawn(again, seed) for seed in range(20)] == first
    assert len({theta.length for theta in first}) == 20
    assert all(0.3 <= t.length <= 1.5 and 0.05 <= t.masspole <= 0.5 for t in first)
    assert all(t.gravity == 9.8 for t in first)  # parameters not named keep the nominal θ_0


def test_the_drawn_theta0_drives_the_dynamics():
    """An episode from a drawn θ_0 is the episode of an env built with that θ_0."""
    env = gym.make(CARTPOLE, nature=DomainRandomisation({"length": Uniform(2.0, 3.0)}))
    theta0 = drawn(env, 3)
    fixed = gym.make(CARTPOLE, params=theta0)
    obs, _ = env.reset(seed=3)
    ref, _ = fixed.reset(seed=3)
    for t in range(8):
        obs, *_ = env.step(t % 2)
        ref, *_ = fixed.step(t % 2)
    np.testing.assert_array_equal(obs["state"], ref["state"])


def test_the_draw_is_hidden_from_the_agent_its_planner_and_the_change_record():
    """No flag, no size, no change time; the planner assumes the nominal θ_0 at every level."""
    for level in ("none", "basic", "detailed"):
        env = gym.make(CARTPOLE, nature=DomainRandomisation(BOX), notification=level)
        obs, _ = env.reset(seed=0)
        obs, *_ = env.step(0)
        assert not obs["env_change"].any() and not obs["delta_change"].any()
        truth = env.unwrapped.ground_truth()
        assert truth.change_times == () and truth.theta0 != env.unwrapped.process.base_theta0
        assert env.unwrapped.process.planning_theta() == env.unwrapped.process.base_theta0


def test_changes_after_the_draw_are_told_on_top_of_the_nominal_theta0():
    """``then=`` moves θ from the draw; ``detailed`` tells the moved parameter, not the draw.

    The planner learns the moved parameter's true value and nothing of the hidden draw of the
    others.
    """
    grows = ScriptedNature({"length": IncrementUpdate(ContinuousScheduler(start=1), k=0.01)})
    nature = DomainRandomisation(BOX, then=grows)
    env = gym.make(CARTPOLE, nature=nature, notification="detailed")
    env.reset(seed=1)
    for _ in range(3):
        obs, *_ = env.step(0)
    process = env.unwrapped.process
    truth = env.unwrapped.ground_truth()
    assert truth.change_times == (1, 2, 3)  # θ_3 is chosen; transition 3 is still to come
    assert obs["env_change"].tolist() == [0, 0, 0, 1, 0, 0]  # length, in the documented order
    planned = process.planning_theta()
    assert planned.length == pytest.approx(truth.theta0.length + 0.02)
    assert planned.masspole == process.base_theta0.masspole != truth.theta0.masspole


def test_explicit_reset_params_set_theta0_and_nothing_is_drawn():
    """reset(options={"params": ...}) states θ_0 itself: no draw overrides it."""
    env = gym.make(CARTPOLE, nature=DomainRandomisation(BOX))
    env.reset(seed=0, options={"params": {"length": 0.77}})
    assert env.unwrapped.ground_truth().theta0.length == 0.77
    assert env.unwrapped.ground_truth().theta0.masspole == 0.1


def test_the_game_and_the_vector_env_draw_per_episode_and_sub_env():
    """The AEC game draws as the view does; each sub-env of a vector env draws from its own seed."""
    game = ns_pz.make(CARTPOLE, nature=DomainRandomisation(BOX))
    game.reset(seed=4)
    env = gym.make(CARTPOLE, nature=DomainRandomisation(BOX))
    assert game.unwrapped.process.theta0 == drawn(env, 4)
    vector = ns_pz.make_vec(CARTPOLE, 3, nature=DomainRandomisation(BOX))
    vector.reset(seed=10)
    lengths = [p.theta0.length for p in vector._processes]
    assert lengths == [drawn(env, seed).length for seed in (10, 11, 12)]


def test_distributions_draw_inside_their_support():
    """Truncated normal, log-uniform, weighted choice and Dirichlet draw what they promise."""
    rng = np.random.default_rng(0)
    normal = Normal(1.0, 2.0, low=0.5, high=1.5)
    values = [normal.sample(rng) for _ in range(500)]
    assert 0.5 <= min(values) and max(values) <= 1.5
    log = [LogUniform(0.01, 100.0).sample(rng) for _ in range(2000)]
    assert 0.4 < np.mean(np.log10(log) < 0) < 0.6  # as many below 1 as above
    assert Choice([0.1, 0.2], weights=[0, 1]).sample(rng) == 0.2
    vector = Dirichlet((50.0, 1.0, 1.0)).sample(rng)
    assert sum(vector) == pytest.approx(1.0, abs=1e-12) and vector[0] > 0.7


def test_randomised_slip_vectors_on_a_grid_world():
    """A grid world's slip vector is randomised by Dirichlet or by a choice of vectors."""
    nature = DomainRandomisation({"slip": Dirichlet((8.0, 1.0, 1.0))})
    env = gym.make("ns_pz/FrozenLake-v0", nature=nature)
    slips = {drawn(env, seed).slip for seed in range(5)}
    assert len(slips) == 5
    choice = DomainRandomisation({"slip": Choice([(1.0, 0.0, 0.0), (0.5, 0.25, 0.25)])})
    env = gym.make("ns_pz/FrozenLake-v0", nature=choice)
    assert {drawn(env, seed).slip for seed in range(20)} == {(1.0, 0.0, 0.0), (0.5, 0.25, 0.25)}


def test_bad_randomisation_is_refused_before_any_episode():
    """Draws a parameter cannot take, unknown names and bad distributions are named at once."""
    with pytest.raises(ValueError, match=r"Uniform\(-1.0, 0.5\) draws CartPoleParams.masspole"):
        gym.make(CARTPOLE, nature=DomainRandomisation({"masspole": Uniform(-1.0, 0.5)}))
    with pytest.raises(UnknownParam, match="lenght"):
        gym.make(CARTPOLE, nature=DomainRandomisation({"lenght": Uniform(0.5, 1.0)}))
    with pytest.raises(TypeError, match="Dirichlet draws probability vectors"):
        gym.make(CARTPOLE, nature=DomainRandomisation({"length": Dirichlet((1.0, 1.0))}))
    with pytest.raises(TypeError, match="probability vector"):
        gym.make("ns_pz/FrozenLake-v0", nature=DomainRandomisation({"slip": Uniform(0, 1)}))
    with pytest.raises(ValueError, match="4 entries; FrozenLakeParams.slip has 3 outcomes"):
        gym.make("ns_pz/FrozenLake-v0", nature=DomainRandomisation({"slip": Dirichlet((1,) * 4)}))
    with pytest.raises(ValueError, match="at least 2 entries"):
        Dirichlet((1.0,))
    with pytest.raises(TypeError, match="distributions\\['length'\\]=0.5"):
        DomainRandomisation({"length": 0.5})
    with pytest.raises(ValueError, match="low <= high"):
        Uniform(2.0, 1.0)
    with pytest.raises(ValueError, match="lies outside"):
        Normal(5.0, 1.0, low=0.0, high=1.0)
    with pytest.raises(ValueError, match="weights="):
        Choice([1.0, 2.0], weights=[1.0])


def test_a_sampler_of_ones_own_and_its_mistakes():
    """A user's sampler draws from nature's generator; one returning no mapping is named."""

    def sampler(theta0, rng):
        return {"length": theta0.length * rng.uniform(0.5, 2.0)}

    env = gym.make(CARTPOLE, nature=DomainRandomisation(sampler))
    assert 0.25 <= drawn(env, 0).length <= 1.0
    env = gym.make(CARTPOLE, nature=DomainRandomisation(lambda theta0, rng: 0.7))
    with pytest.raises(TypeError, match="returned 0.7; it must return a mapping"):
        env.reset(seed=0)


def test_theta_sets_grid_and_split():
    """A product grid, a seeded partition into train and test members, a seeded sample."""
    grid = ThetaSet.grid({"length": [0.5, 1.0, 1.5], "masspole": [0.1, 0.2]})
    assert len(grid) == 6 and grid.names() == ["length", "masspole"]
    assert grid[5] == {"length": 1.5, "masspole": 0.2}
    train, test = grid.split(1 / 3, seed=0)
    assert (len(train), len(test)) == (4, 2)
    assert sorted(map(str, list(train) + list(test))) == sorted(map(str, grid))
    assert grid.split(1 / 3, seed=0)[1].members == test.members
    assert any(grid.split(1 / 3, seed=s)[1].members != test.members for s in range(1, 5))
    with pytest.raises(ValueError, match="test_fraction=0.01 of 6 members leaves a part empty"):
        grid.split(0.01, seed=0)
    sampled = ThetaSet.sample({"length": Uniform(0.5, 1.0)}, 4, seed=3)
    assert sampled.members == ThetaSet.sample({"length": Uniform(0.5, 1.0)}, 4, seed=3).members
    with pytest.raises(ValueError, match="non-empty"):
        ThetaSet([])


def test_randomising_over_a_training_set_draws_only_its_members():
    """Randomising over the training part of a split never shows a test member."""
    train, test = ThetaSet.grid({"length": [0.4, 0.6, 0.8, 1.0, 1.2]}).split(0.4, seed=1)
    env = gym.make(CARTPOLE, nature=DomainRandomisation(train))
    seen = {drawn(env, seed).length for seed in range(40)}
    assert seen == {member["length"] for member in train}
    assert not seen & {member["length"] for member in test}
    with pytest.raises(ValueError, match="length"):
        gym.make(CARTPOLE, nature=DomainRandomisation(ThetaSet([{"length": -1.0}])))
