"""ADA-MCTS (agents/search/ada_mcts.py) and its Dirichlet learner (agents/search/dirichlet.py)."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import run_episode, value_iteration
from ns_pz.agents.search import ADAMCTS, MCTS
from ns_pz.agents.search.ada_mcts import manhattan, pessimistic_kernel
from ns_pz.agents.search.compiled import numba_available
from ns_pz.agents.search.dirichlet import DirichletLearner, atoms_of, epistemic
from ns_pz.agents.search.table_model import OutcomeTableModel
from tables_for_tests import coin_table, table

import ns_pz
from ns_pz.planning import TabularOutcomes

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba (the fast extra) missing")
BACKENDS = ["python", pytest.param("compiled", marks=needs_numba)]


def lake(slip: tuple[float, float, float] = (0.7, 0.15, 0.15)):
    """FrozenLake 4x4 after reset, and its planning model (θ_0 = ``slip``)."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": slip})
    env.reset(seed=0)
    return env, env.planning_model()


def sample(outcomes, state, action, rng):
    """One transition (next state, reward, terminal) drawn from a table."""
    k = rng.choice(outcomes.probs.shape[2], p=outcomes.probs[state, action])
    return (
        int(outcomes.next_states[state, action, k]),
        float(outcomes.rewards[state, action, k]),
        bool(outcomes.terminals[state, action, k]),
    )


def test_atoms_merge_slots_with_the_same_outcome():
    """At the top-left corner, UP and LEFT both stay put: one atom for two slots."""
    _, model = lake()
    table = model.outcomes
    atoms = atoms_of(table.next_states, table.rewards, table.terminals)
    # state 0, action LEFT: intended LEFT stays at 0, +1 = DOWN -> 4, -1 = UP stays at 0
    assert table.next_states[0, 0].tolist() == [0, 4, 0]
    assert atoms[0, 0].tolist() == [0, 1, 0]
    assert atoms[6, 0].tolist() == [0, 1, 2]


@pytest.mark.parametrize("pooling", ["state_action", "shared"])
def test_posterior_converges_to_the_changed_kernel(pooling):
    """Transitions from p=0.4 teach M1 the new kernel; its epistemic uncertainty shrinks."""
    _, model = lake()
    base = model.outcomes
    true = model.family.outcomes(model.family.params_cls(slip=(0.4, 0.3, 0.3)))
    learner = DirichletLearner(base.next_states, base.rewards, base.terminals, pooling=pooling)
    rng = np.random.default_rng(0)
    eu_before = learner.epistemic()[6, 1]
    states = [1, 2, 4, 6, 8, 9, 10, 13, 14] if pooling == "shared" else [6]
    for _ in range(4000):
        state = int(rng.choice(states))
        action = 1 if pooling == "state_action" else int(rng.integers(4))
        assert learner.update(state, action, *sample(true, state, action, rng))
    np.testing.assert_allclose(learner.mean()[6, 1], true.probs[6, 1], atol=0.03)
    assert learner.epistemic()[6, 1] < eu_before / 50
    if pooling == "shared":  # every state learned, the corner's merged slots included
        np.testing.assert_allclose(learner.mean()[0, 0], [0.4, 0.3, 0.3], atol=0.03)


def test_unexplained_transitions_are_counted_not_learned():
    """A transition outside the structural support teaches nothing."""
    _, model = lake()
    table = model.outcomes
    learner = DirichletLearner(table.next_states, table.rewards, table.terminals)
    before = learner.mean().copy()
    assert not learner.update(6, 0, 15, 1.0, True)
    assert learner.unexplained == 1
    np.testing.assert_array_equal(learner.mean(), before)


def test_pessimistic_kernel_worked_out_by_hand():
    """State 6 of the lake (holes left and right), action LEFT, θ_0 = (0.7, 0.15, 0.15).

    With holes worth -1 the worst outcome is the hole 5 (slot 0). W1 from T0 to the Dirac on it
    is 0.15 * d(10, 5) + 0.15 * d(2, 5) = 0.15 * 2 + 0.15 * 2 = 0.6 (Manhattan), so radius 0.3
    gives λ = 0.5: (0.85, 0.075, 0.075). Without danger, the Dirac itself.
    """
    _, model = lake()
    table = model.outcomes
    values = np.where(table.terminals & (table.rewards <= 0), -1.0, table.rewards)
    probs = np.asarray(table.probs, dtype=float)
    mixed = pessimistic_kernel(probs, table.next_states, values, True, 0.3, manhattan(4))
    np.testing.assert_allclose(mixed[6, 0], [0.85, 0.075, 0.075])
    full = pessimistic_kernel(probs, table.next_states, values, False, 0.3, None)
    np.testing.assert_array_equal(full[6, 0], [1.0, 0.0, 0.0])
    # where no outcome of positive probability is negative, T0 itself
    np.testing.assert_array_equal(full[0, 0], probs[0, 0])
    with pytest.raises(ValueError, match="ground metric"):
        pessimistic_kernel(probs, table.next_states, values, True, 0.3, None)


def test_danger_counts_negative_action_next_state_pairs():
    """State 6 touches two holes: 6 (action, hole) pairs; state 0 touches none."""
    _, model = lake()
    agent = ADAMCTS(failure_reward=-1.0)
    values = agent._values(model.outcomes)
    assert agent.in_danger(values, model.outcomes, 6)
    assert not agent.in_danger(values, model.outcomes, 0)
    assert ADAMCTS(failure_reward=-1.0, danger_threshold=6).in_danger(values, model.outcomes, 6)
    assert not ADAMCTS(failure_reward=-1.0, danger_threshold=7).in_danger(values, model.outcomes, 6)


def test_sampling_kernel_switches_from_pessimistic_base_to_learned_model():
    """Before warm-up: P̃0. After it, where M1 is sure and the world is less noisy: T1."""
    _, model = lake((0.7, 0.15, 0.15))
    true = model.family.outcomes(model.family.params_cls(slip=(1.0, 0.0, 0.0)))
    agent = ADAMCTS(iterations=5, depth=5, warmup=20, pooling="shared", failure_reward=-1.0)
    agent.reset(np.random.default_rng(0))
    agent.act({"state": 6}, model)
    phase_one = agent.last_kernel
    # state 6, DOWN: intended 10 (free), slips to the holes 7 and 5: the Dirac on hole 7
    np.testing.assert_array_equal(phase_one[6, 1], [0.0, 1.0, 0.0])
    rng = np.random.default_rng(1)
    for _ in range(300):
        state, action = int(rng.choice([0, 1, 2, 4, 6, 8, 9, 10, 13, 14])), int(rng.integers(4))
        agent.observe(
            {"state": state}, action, 0.0, {"state": sample(true, state, action, rng)[0]}, False
        )
    assert agent.learning_started
    agent.act({"state": 6}, model)
    np.testing.assert_array_equal(agent.last_kernel[6, 1], agent.learner.mean()[6, 1])
    assert agent.last_kernel[6, 1, 0] > 0.98
    # A noisier world (AU_1 > AU_0) with kappa = 1e4 turns back to the pessimistic base
    noisy = model.family.outcomes(model.family.params_cls(slip=(1 / 3, 1 / 3, 1 / 3)))
    agent.reset(np.random.default_rng(0))
    agent.act({"state": 6}, model)
    for _ in range(300):
        state, action = int(rng.choice([0, 1, 2, 4, 6, 8, 9, 10, 13, 14])), int(rng.integers(4))
        next_state, reward, done = sample(noisy, state, action, rng)
        agent.observe({"state": state}, action, reward, {"state": next_state}, done)
    agent.act({"state": 6}, model)
    assert agent.learning_started
    np.testing.assert_array_equal(agent.last_kernel[6, 1], [0.0, 1.0, 0.0])


def bridge(base_p: float):
    """The paper's Bridge after reset, planning model at θ_0 = (p, (1-p)/2, (1-p)/2)."""
    slip = (base_p, (1 - base_p) / 2, (1 - base_p) / 2)
    env = ns_pz.make_gym("ns_pz/Bridge-v0", params={"slip": slip})
    env.reset(seed=0)
    return env.planning_model()


def feed(agent, family, true, rng, count):
    """``count`` real transitions of the changed world at random free cells."""
    free = [s for s in range(true.probs.shape[0]) if family.cell(s) in "SF"]
    for _ in range(count):
        state, action = int(rng.choice(free)), int(rng.integers(4))
        next_state, reward, done = sample(true, state, action, rng)
        agent.observe({"state": state}, action, reward, {"state": next_state}, done)


def test_after_a_change_ada_mcts_decides_better_than_stale_mcts():
    """Bridge, θ_0 p=0.7 changed to p=0.4: the narrow bridge becomes deadly.

    True optimal Q at the start: LEFT (long safe path) 0.11, RIGHT (bridge) -0.25. Stale UCT
    (m=500 as in the paper) with random rollouts on θ_0 mostly goes RIGHT; ADA-MCTS, after 300
    real transitions of the new world, sees it is noisier and plans pessimistically. Over 20
    seeds the true value of its first action is higher in at least 15 (a one-sided sign test's
    p < 0.025 if both were equally good).
    """
    model = bridge(0.7)
    family, start = model.family, model.get_state()
    true = family.outcomes(family.params_cls(slip=(0.4, 0.3, 0.3)))
    _, q_true = value_iteration(true, 0.99)
    better = 0
    ada_values, stale_values = [], []
    for seed in range(20):
        agent = ADAMCTS(iterations=500, depth=50)
        agent.reset(np.random.default_rng(seed))
        agent.act({"state": start}, model)
        feed(agent, family, true, np.random.default_rng(100 + seed), 300)
        ada = agent.act({"state": start}, model)
        stale = MCTS(iterations=500, depth=50)
        stale.reset(np.random.default_rng(seed))
        stale_action = stale.act({"state": start}, model)
        ada_values.append(q_true[start, ada])
        stale_values.append(q_true[start, stale_action])
        better += q_true[start, ada] > q_true[start, stale_action]
    assert better >= 15, (ada_values, stale_values)
    assert np.mean(ada_values) > np.mean(stale_values) + 0.1


def test_learning_changes_the_decision_the_way_the_new_world_asks():
    """Bridge, θ_0 p=0.7 changed to deterministic: after learning, take the short bridge.

    Fresh (phase 1) ADA-MCTS is pessimistic about the bridge and goes LEFT; having seen 300
    deterministic transitions (shared pooling), it plans with T1 and goes RIGHT, the true optimum
    (Q 0.98 vs 0.97), in at least 15 of 20 seeds, while the fresh agent does in at most 5.
    """
    model = bridge(0.7)
    family, start = model.family, model.get_state()
    true = family.outcomes(family.params_cls(slip=(1.0, 0.0, 0.0)))
    _, q_true = value_iteration(true, 0.99)
    assert q_true[start].argmax() == 2
    fresh_right = learned_right = 0
    for seed in range(20):
        agent = ADAMCTS(iterations=300, depth=50, pooling="shared")
        agent.reset(np.random.default_rng(seed))
        fresh_right += agent.act({"state": start}, model) == 2
        feed(agent, family, true, np.random.default_rng(100 + seed), 300)
        learned_right += agent.act({"state": start}, model) == 2
    assert learned_right >= 15 and fresh_right <= 5, (learned_right, fresh_right)


def test_episode_runs_learns_and_reset_clears_the_learner():
    """In the evaluation loop every real step is counted; a new episode starts from the prior."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (0.7, 0.15, 0.15)})
    agent = ADAMCTS(iterations=20, depth=20, warmup=3)
    first = run_episode(env, agent, seed=1)
    assert agent.transitions == first.length
    assert agent.learner is not None and agent.learner.visits.sum() == first.length
    again = run_episode(
        ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (0.7, 0.15, 0.15)}), agent, seed=1
    )
    assert again == first  # reset cleared M1: the same seed replays the same episode
    agent.reset(np.random.default_rng(0))
    assert agent.learner is None and agent.transitions == 0


def test_non_tabular_models_are_refused():
    """CartPole has no outcome table: ADA-MCTS says what it needs."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    agent = ADAMCTS()
    agent.reset(np.random.default_rng(0))
    with pytest.raises(ValueError, match="needs a tabular planning model.*PlanningModel"):
        agent.act({"state": 0}, env.planning_model())
    with pytest.raises(ValueError, match="needs a tabular planning model.*NoneType"):
        agent.act({"state": 0}, None)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"iterations": 0}, ValueError, r"iterations=0 must be >= 1"),
        ({"gamma": 2.0}, ValueError, r"gamma=2.0 must lie in \[0, 1\]"),
        ({"delta": -0.1}, ValueError, r"delta=-0.1 must be >= 0"),
        ({"kappa": float("inf")}, TypeError, r"kappa=inf must be a finite number"),
        ({"warmup": -5}, ValueError, r"warmup=-5 must be >= 0"),
        ({"radius": -1}, ValueError, r"radius=-1 must be >= 0"),
        ({"base_concentration": 0}, ValueError, r"base_concentration=0 must be finite and > 0"),
        ({"pooling": "global"}, ValueError, r"pooling='global' is not a pooling"),
        ({"failure_reward": "low"}, TypeError, r"failure_reward='low' must be a finite number"),
    ],
)
def test_bad_hyper_parameters_are_refused(kwargs, error, match):
    """Each bad value is named with what is allowed."""
    with pytest.raises(error, match=match):
        ADAMCTS(**kwargs)


def test_bad_learner_arguments_are_refused():
    """The learner checks its pooling and prior."""
    _, model = lake()
    table = model.outcomes
    with pytest.raises(ValueError, match="prior=0.0 must be a finite number > 0"):
        DirichletLearner(table.next_states, table.rewards, table.terminals, prior=0.0)


def test_pessimism_along_the_cliff_does_not_fade_towards_the_goal():
    """CliffWalking, θ_0 = (0.7, 0.1, 0.1, 0.1), the agent in danger on row 2, radius 1.

    Action RIGHT from (2, c): intended (2, c+1), +1 = DOWN into the cliff cell (3, c), -1 = UP
    (1, c), reverse (2, c-1). W1 to the Dirac on the cliff, measured between the cells the moves
    enter: 0.7 * 2 + 0.1 * 0 + 0.1 * 2 + 0.1 * 2 = 1.8, so λ = 1/1.8 and P(cliff) = 0.1 + 0.9 λ =
    0.6 on every column. Measured between next states (the cliff teleports to the start (3, 0))
    the cliff looked farther the farther the agent was from the start: 0.46 at column 1, 0.19 at
    column 10.
    """
    env = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0", params={"slip": (0.7, 0.1, 0.1, 0.1)}, goal_reward=100.0
    )
    env.reset(seed=0)
    model = env.planning_model()
    table = model.outcomes
    edge = [2 * 12 + col for col in range(1, 11)]
    assert (table.next_states[edge, 1, 1] == 36).all()  # the start
    assert table.cells[edge, 1, 1].tolist() == [36 + col for col in range(1, 11)]
    agent = ADAMCTS(iterations=2, depth=2)
    agent.reset(np.random.default_rng(0))
    for root in (edge[0], edge[-1]):  # the root's danger decides the mixture for every state
        model.set_state(root)
        agent.act({"state": root}, model)
        assert agent.in_danger(agent._values(table), table, root)
        cliff = table.rewards[edge, 1] == -100.0
        p_cliff = (agent.last_kernel[edge, 1] * cliff).sum(axis=1)
        np.testing.assert_allclose(p_cliff, 0.6, rtol=1e-12)


def test_landing_cells_are_the_next_states_where_nothing_teleports():
    """FrozenLake and the Bridge move the agent into the cell it enters."""
    for env_id in ("ns_pz/FrozenLake-v0", "ns_pz/Bridge-v0"):
        env = ns_pz.make_gym(env_id)
        env.reset(seed=0)
        table = env.planning_model().outcomes
        np.testing.assert_array_equal(table.cells, table.next_states)
        assert not table.cells.flags.writeable


def test_epistemic_is_the_sum_of_the_dirichlet_posterior_variances():
    """EU = Σ_i Var(p_i), Var(p_i) = α_i (α_0 - α_i) / (α_0² (α_0 + 1)), on random α."""
    alpha = np.random.default_rng(0).uniform(0.1, 5.0, size=(3, 2, 4))
    total = alpha.sum(axis=2, keepdims=True)
    variances = alpha * (total - alpha) / (total**2 * (total + 1.0))
    np.testing.assert_allclose(epistemic(alpha), variances.sum(axis=2), rtol=1e-12)
    # one atom of concentration 1 against two of 1: Beta(1, 1) has variance 1/12 per side
    np.testing.assert_allclose(epistemic(np.array([[[1.0, 1.0]]])), [[1 / 6]], rtol=1e-12)


def fork_table() -> TabularOutcomes:
    """State 0, one action: to state 1 or 2 with T0 = (0.5, 0.5), nothing negative; 1, 2 end."""
    ends = [(1.0, 0, 0.0, True), (0.0, 0, 0.0, True)]
    return table([[[(0.5, 1, 0.0, False), (0.5, 2, 0.0, False)]], [ends], [ends]])


def test_m0_epistemic_uncertainty_divides_by_its_concentration_plus_one():
    """Which side of δ = 0 EU_1 falls on decides between T0 (phase 1) and the learned T1.

    M0 = Dirichlet(4 · (0.5, 0.5)): EU_0 = 0.5 / (4 + 1) = 0.1. M1 after one transition to
    state 1, prior 1: α = (2, 1), EU_1 = (1 - 4/9 - 1/9) / 4 = 1/9 > EU_0, so M1 is still
    unsure and the kernel is T0 (nothing is negative, so P̃0 = T0). EU_0 = 0.5 / 4 = 0.125
    would trust M1 and sample its mean (2/3, 1/3). (AU_1 < AU_0 = ln 2: no noisier-world mix.)
    """
    fork = fork_table()
    model = OutcomeTableModel(fork, 0, np.random.default_rng(0))
    agent = ADAMCTS(iterations=2, depth=0, warmup=1, delta=0.0, base_concentration=4.0)
    agent.reset(np.random.default_rng(0))
    agent.act({"state": 0}, model)
    agent.observe({"state": 0}, 0, 0.0, {"state": 1}, False)
    agent.act({"state": 0}, model)
    np.testing.assert_allclose(agent.learner.epistemic()[0, 0], 1 / 9, rtol=1e-12)
    np.testing.assert_array_equal(agent.last_kernel[0, 0], [0.5, 0.5])
    agent = ADAMCTS(iterations=2, depth=0, warmup=1, delta=0.0, base_concentration=5.0)
    agent.reset(np.random.default_rng(0))  # EU_0 = 0.5 / 6 < 1/9 as well: still T0
    agent.act({"state": 0}, model)
    agent.observe({"state": 0}, 0, 0.0, {"state": 1}, False)
    agent.act({"state": 0}, model)
    np.testing.assert_array_equal(agent.last_kernel[0, 0], [0.5, 0.5])
    agent = ADAMCTS(iterations=2, depth=0, warmup=1, delta=0.0, base_concentration=3.0)
    agent.reset(np.random.default_rng(0))  # EU_0 = 0.5 / 4 = 0.125 > 1/9: M1 is trusted
    agent.act({"state": 0}, model)
    agent.observe({"state": 0}, 0, 0.0, {"state": 1}, False)
    agent.act({"state": 0}, model)
    np.testing.assert_allclose(agent.last_kernel[0, 0], [2 / 3, 1 / 3], rtol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_ada_mcts_plays_the_most_visited_action(backend):
    """Exploration c = 0, three iterations: action 1 pays 1, is taken again greedily, pays 0.

    Root: visits [1, 2], Q [0.6, 0.5]: ADA-MCTS plays 1 (the most visited), not 0 (best Q).
    """
    coin = coin_table()
    agent = ADAMCTS(iterations=3, depth=0, c=0.0, backend=backend)
    agent.reset(np.random.default_rng(0))
    action = agent.act({"state": 0}, OutcomeTableModel(coin, 0, np.random.default_rng(2)))
    assert agent.last_result.visits.tolist() == [1, 2]
    np.testing.assert_array_equal(agent.last_result.values, [0.6, 0.5])
    assert action == 1


def test_the_real_state_in_danger_turns_the_dirac_into_the_w1_mixture():
    """FrozenLake θ_0 = (0.7, 0.15, 0.15), radius 1; kernel of (6, DOWN) from two roots.

    (6, DOWN): 0.7 to 10, 0.15 to the holes 7 and 5; the worst is hole 7 (first of the ties).
    From root 6 (two holes beside it: in danger), W1 to the Dirac on 7 is 0.7 * 2 + 0.15 * 2 =
    1.7, λ = 1 / 1.7: (1 - λ) T0 + λ δ_7. From root 0 (no hole beside it), the Dirac δ_7.
    """
    _, model = lake()
    agent = ADAMCTS(iterations=2, depth=2, failure_reward=-1.0)
    agent.reset(np.random.default_rng(0))
    lam = 1 / 1.7
    for root, expected in (
        (6, (1 - lam) * np.array([0.7, 0.15, 0.15]) + lam * np.array([0.0, 1.0, 0.0])),
        (0, np.array([0.0, 1.0, 0.0])),
    ):
        model.set_state(root)
        agent.act({"state": root}, model)
        np.testing.assert_allclose(agent.last_kernel[6, 1], expected, rtol=1e-12, atol=0)


def test_danger_counts_distinct_action_cell_pairs_at_the_threshold():
    """Cells 1 and 2 are holes (-1). Action 0 lands in 1, 1, 2; action 1 in 1, 3, 3.

    Negative (action, cell) pairs: (0, 1), (0, 2), (1, 1): three, from four negative slots and
    two distinct cells. In danger at threshold 3, not at 4.
    """
    hole = [(1.0, 1, -1.0, True), (0.0, 1, -1.0, True), (0.0, 1, -1.0, True)]
    rows = [
        [
            [(0.5, 1, -1.0, True), (0.25, 1, -1.0, True), (0.25, 2, -1.0, True)],
            [(0.5, 1, -1.0, True), (0.25, 3, 0.0, False), (0.25, 3, 0.0, False)],
        ],
        [hole, hole],
        [hole, hole],
        [hole, hole],
    ]
    outcomes = table(rows)
    values = np.asarray(outcomes.rewards)
    assert ADAMCTS(danger_threshold=3).in_danger(values, outcomes, 0)
    assert not ADAMCTS(danger_threshold=4).in_danger(values, outcomes, 0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"warmup": 2.5}, "warmup=2.5 must be an int"),
        ({"danger_threshold": 1.5}, "danger_threshold=1.5 must be an int"),
        ({"base_concentration": True}, "base_concentration=True"),
        ({"base_concentration": float("inf")}, "base_concentration=inf"),
        ({"failure_reward": float("nan")}, "failure_reward=nan"),
        ({"failure_reward": True}, "failure_reward=True"),
        ({"prior": -1.0}, "prior=-1.0"),
        ({"prior": True}, "prior=True"),
        ({"backend": "gpu"}, "backend='gpu'"),
    ],
)
def test_ada_mcts_refuses_what_it_would_truncate_or_turn_into_nan(kwargs, match):
    """Counts are ints (2.5 was truncated), concentrations and rewards finite numbers."""
    with pytest.raises((TypeError, ValueError), match=match):
        ADAMCTS(**kwargs)
