"""RATS on the tabular envs: hand-checked decisions, the DAG, NS-Gym's behaviour, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import run_episode
from ns_pz.agents.search import SearchResult
from ns_pz.agents.search.rats import grid_distances, rats, rats_agent

import ns_pz

RNG = np.random.default_rng(0)
VARIANTS = ("dirac_support", "wasserstein_direct", "wasserstein_lp")
LEFT, DOWN, RIGHT, UP = range(4)


def model_of(env_id: str, p: float = 0.7, **kwargs):
    """A planning model of ``env_id`` under the equal-split slip vector with intended prob p."""
    size = 4 if "Cliff" in env_id else 3
    slip = (p,) + ((1.0 - p) / (size - 1),) * (size - 1)
    env = ns_pz.make_gym(env_id, params={"slip": slip}, **kwargs)
    env.reset(seed=0)
    return env.planning_model()


def test_depth_two_decision_next_to_the_frozen_lake_goal_by_hand():
    """State 14, left of the goal, by hand.

    Depth-1 children are worth max_b R̄(child, b): 14 -> 0.7 (RIGHT), 13 and 10 -> 0; the goal
    (terminal) is worth its reward 1.

    Dirac: nature picks the worst child, so Q = R̄ + γ·0 = [0, .15, .7, .15]. Wasserstein: the
    root budget is 0, so nature plays w0: Q(RIGHT) = .7 + .99 (.7·1 + .15·0 + .15·.7).
    """
    model = model_of("ns_pz/FrozenLake-v0")
    dirac = rats(model, 14, RNG, depth=2, worst_case="dirac_support")
    np.testing.assert_allclose(dirac.values, [0.0, 0.15, 0.7, 0.15], atol=1e-15)
    expected = [0.99 * 0.105, 0.15 + 0.99 * 0.64, 0.7 + 0.99 * 0.805, 0.15 + 0.99 * 0.15]
    for variant in VARIANTS[1:]:
        result = rats(model, 14, RNG, depth=2, worst_case=variant)
        np.testing.assert_allclose(result.values, expected, rtol=1e-14)
        assert result.action == RIGHT
    assert isinstance(dirac, SearchResult) and dirac.action == RIGHT
    assert dirac.visits.tolist() == [1, 1, 1, 1]


def test_golden_depth_three_decision_on_the_bridge():
    """From the Bridge start (p = 0.7, γ .99, L_p = τ = 1) every variant heads left, the safe way.

    Dirac, by hand: LEFT leads to 19, 28 or 12; from 28 every action has a hole among its
    outcomes (R̄ = .15·(-1)) and nature sends the agent into it: v(28) = -.15 - .99 = -1.14, so
    Q(LEFT) = .99·(-1.14) = -1.1286.
    """
    model = model_of("ns_pz/Bridge-v0")
    golden = {
        "dirac_support": [-1.1286, -1.2771, -1.2771, -1.2771],
        "wasserstein_direct": [-0.2356695, -0.6821356235, -0.8527900765, -0.6821356235],
        "wasserstein_lp": [-0.2356695, -0.7002963, -0.9375399, -0.7002963],
    }
    for variant, values in golden.items():
        result = rats(model, 20, RNG, depth=3, worst_case=variant)
        np.testing.assert_allclose(result.values, values, rtol=1e-9)
        assert result.action == LEFT


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize(
    "env_id, states, kwargs",
    [
        ("ns_pz/FrozenLake-v0", (0, 6, 9, 14), {}),
        ("ns_pz/Bridge-v0", (17, 20, 22), {}),
        ("ns_pz/CliffWalking-v0", (24, 36, 35), {"goal_reward": 100.0}),
    ],
)
def test_memoised_dag_equals_the_full_tree(variant, env_id, states, kwargs):
    """Same values bit for bit, far fewer nodes; both terminal-value modes."""
    model = model_of(env_id, **kwargs)
    for state in states:
        for terminal_value in ("env", "fl_hack"):
            options = {"depth": 3, "worst_case": variant, "terminal_value": terminal_value}
            dag = rats(model, state, RNG, memoise=True, **options)
            tree = rats(model, state, RNG, memoise=False, **options)
            assert np.array_equal(dag.values, tree.values) and dag.action == tree.action
            assert dag.stats["decision_nodes"] < tree.stats["decision_nodes"]


@pytest.mark.parametrize(
    "env_id, kwargs", [("ns_pz/Bridge-v0", {}), ("ns_pz/CliffWalking-v0", {"goal_reward": 100.0})]
)
def test_natures_are_ordered_dirac_lp_direct_nominal(env_id, kwargs):
    """Dirac <= LP <= direct <= nominal, and L_p = 0 (or τ = 0) gives the nominal values.

    The exact LP nature is stronger than the direct method's feasible point and weaker than an
    unbounded one; with no budget both Wasserstein natures play the snapshot.
    """
    model = model_of(env_id, **kwargs)
    for state in (9, 20, 26, 36) if "Cliff" in env_id else (17, 18, 20, 21, 22):
        values = {v: rats(model, state, RNG, depth=4, worst_case=v).values for v in VARIANTS}
        assert (values["dirac_support"] <= values["wasserstein_lp"] + 1e-12).all()
        assert (values["wasserstein_lp"] <= values["wasserstein_direct"] + 1e-12).all()
        nominal = rats(model, state, RNG, depth=4, worst_case="wasserstein_lp", lipschitz_p=0.0)
        direct0 = rats(model, state, RNG, depth=4, worst_case="wasserstein_direct", tau=0.0)
        assert np.array_equal(nominal.values, direct0.values)
        assert (values["wasserstein_direct"] <= nominal.values + 1e-12).all()
    assert (values["wasserstein_lp"] < values["wasserstein_direct"] - 1e-6).any()


def test_dirac_variant_behaves_as_the_ns_gym_paper_ran_it():
    """The Dirac variant with the env's rewards reproduces NS-Gym's FrozenLake failure.

    Every action ties at 0 away from the goal, the first (LEFT) wins, and the agent never
    leaves column 0: success 0.

    Nature may pick an outcome of probability 0: on a deterministic lake (p = 1) RIGHT next to
    the goal is still worth only R̄ = 1, while a Wasserstein nature with budget 0 at the root
    must let the agent in (1 + γ·1).
    """
    model = model_of("ns_pz/FrozenLake-v0")
    assert rats(model, 0, RNG).values.tolist() == [0.0, 0.0, 0.0, 0.0]
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (0.7, 0.15, 0.15)})
    agent = rats_agent(depth=3, gamma=0.99)
    for seed in range(10):
        episode = run_episode(env, agent, seed)
        assert episode.episode_return == 0.0
    deterministic = model_of("ns_pz/FrozenLake-v0", p=1.0)
    assert rats(deterministic, 14, RNG, depth=2).values[RIGHT] == 1.0
    lp = rats(deterministic, 14, RNG, depth=2, worst_case="wasserstein_lp")
    assert lp.values[RIGHT] == pytest.approx(1.99)
    # The paper-era FrozenLake hack: a hole counts -1 in R̄, so RIGHT from 4 (into hole 5) is bad.
    hack = rats(model, 4, RNG, depth=1, terminal_value="fl_hack")
    np.testing.assert_allclose(hack.values, [0.0, -0.15, -0.7, -0.15])
    assert rats(model, 4, RNG, depth=1).values.tolist() == [0.0, 0.0, 0.0, 0.0]


def test_grid_distances_are_manhattan():
    """Ground metric: |Δrow| + |Δcol| on the family's grid."""
    family = ns_pz.make_gym("ns_pz/Bridge-v0").family
    distances = grid_distances(family)
    assert distances.shape == (40, 40)
    assert distances[20, 23] == 3 and distances[0, 39] == 4 + 7 and distances[9, 9] == 0


def test_rats_rejects_bad_input():
    """Every hyper-parameter and the model are checked, with the value in the message."""
    model = model_of("ns_pz/FrozenLake-v0")
    cases = [
        ({"depth": 0}, ValueError, "depth=0 must be >= 1"),
        ({"depth": 2.5}, TypeError, "depth=2.5 must be an int"),
        ({"gamma": 1.5}, ValueError, r"gamma=1.5 must lie in \[0, 1\]"),
        ({"lipschitz_p": -1.0}, ValueError, "lipschitz_p=-1.0 must be finite and >= 0"),
        ({"tau": float("nan")}, ValueError, "tau=nan must be finite"),
        ({"worst_case": "lp"}, ValueError, "worst_case='lp' is not one of"),
        ({"terminal_value": "zero"}, ValueError, "terminal_value='zero' is not one of"),
        ({"memoise": 1}, TypeError, "memoise=1 must be a bool"),
    ]
    for kwargs, error, message in cases:
        with pytest.raises(error, match=message):
            rats(model, 0, RNG, **kwargs)
        with pytest.raises(error, match=message):
            rats_agent(**kwargs)
    with pytest.raises(ValueError, match="root_state=16 is outside 0..15"):
        rats(model, 16, RNG)
    cartpole = ns_pz.make_gym("ns_pz/CartPole-v0")
    cartpole.reset(seed=0)
    with pytest.raises(TypeError, match="needs a tabular planning model"):
        rats(cartpole.planning_model(), 0, RNG)
    with pytest.raises(ValueError, match=r"distances has shape \(3, 3\)"):
        rats(model, 0, RNG, worst_case="wasserstein_lp", distances=np.zeros((3, 3)))

    class NoGrid:
        outcomes = model.outcomes
        family = object()

    with pytest.raises(ValueError, match="has no grid layout"):
        rats(NoGrid(), 0, RNG, worst_case="wasserstein_direct")
    assert rats(NoGrid(), 0, RNG).action == LEFT  # the Dirac nature needs no metric


def test_rats_agent_plays_the_bridge():
    """The agent runs in the env loop; the LP variant crosses safely more often than not."""
    env = ns_pz.make_gym("ns_pz/Bridge-v0", params={"slip": (0.7, 0.15, 0.15)})
    agent = rats_agent(worst_case="wasserstein_lp")
    assert agent.name == "RATS(wasserstein_lp)"
    returns = [run_episode(env, agent, seed).episode_return for seed in range(10)]
    assert set(returns) <= {-1.0, 0.0, 1.0} and np.mean(returns) > 0
