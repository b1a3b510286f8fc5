"""UCT (agents/search/mcts.py) and its compiled kernels (agents/search/_kernels.py)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pytest
from ns_pz.agents import run_episode, value_iteration
from ns_pz.agents.search import MCTS, SearchAgent, uct, uct_tree
from ns_pz.agents.search.compiled import compile_model, numba_available
from ns_pz.agents.search.table_model import OutcomeTableModel
from tables_for_tests import coin_table, table

import ns_pz
from ns_pz.family import EnvFamily
from ns_pz.params import Params, scalar
from ns_pz.planning import TabularOutcomes

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba (the fast extra) missing")
BACKENDS = ["python", pytest.param("compiled", marks=needs_numba)]


def two_step_table() -> TabularOutcomes:
    """Root 0: action 0 pays 1 and ends; action 1 pays 2 to state 2, whose actions pay 10, end."""
    ends = [(1.0, 3, 0.0, True)]
    return table(
        [
            [[(1.0, 1, 1.0, True)], [(1.0, 2, 2.0, False)]],
            [ends, ends],
            [[(1.0, 3, 10.0, True)], [(1.0, 3, 10.0, True)]],
            [ends, ends],
        ]
    )


def env_model(env_id: str, seed: int = 0, **kwargs: object):
    """The planning model of a registered env after reset(seed)."""
    env = ns_pz.make_gym(env_id, **kwargs)
    env.reset(seed=seed)
    return env.planning_model()


@pytest.mark.parametrize("backend", BACKENDS)
def test_three_iterations_build_the_tree_worked_out_by_hand(backend):
    """m=3, gamma=0.5: both root actions tried once, then UCB picks action 1 (Q 7 vs 1).

    Iteration with action 0: 1 (terminal, no rollout). With action 1: 2 + 0.5 * 10 (rollout of
    one step to the terminal reward 10). Third: UCB ties on the bonus, so action 1 (Q 7); the
    existing node of state 2 is entered, one of its actions pays 10 and ends: the new leaf gets
    Q 10 and the root's Q(1) = mean(7, 2 + 0.5 * 10) = 7. Five model steps in all.
    """
    model = OutcomeTableModel(two_step_table(), 0, np.random.default_rng(0))
    tree = uct_tree(
        model,
        0,
        np.random.default_rng(1),
        iterations=3,
        depth=5,
        c=1.0,
        gamma=0.5,
        backend=backend,
    )
    assert tree.num_nodes == 4
    assert tree.simulated_steps == 5
    np.testing.assert_array_equal(tree.visits[0], [1, 2])
    np.testing.assert_array_equal(tree.q[0], [1.0, 7.0])
    assert tree.node_visits[0] == 3
    node_2 = tree.states.index(2)
    assert tree.parent[node_2] == 0 and tree.parent_action[node_2] == 1
    assert tree.node_visits[node_2] == 1 and tree.q[node_2].max() == 10.0
    assert tree.terminal[tree.states.index(1)] and not tree.terminal[node_2]
    leaf = tree.states.index(3)
    assert tree.parent[leaf] == node_2 and tree.terminal[leaf]
    result = uct(model, 0, np.random.default_rng(1), iterations=3, depth=5, c=1.0, gamma=0.5)
    assert result.action == 1
    np.testing.assert_array_equal(result.values, [1.0, 7.0])


@pytest.mark.parametrize("backend", BACKENDS)
def test_golden_frozen_lake_decision(backend):
    """Fixed generators give a fixed decision and tree (recorded once, equal on both paths)."""
    model = env_model("ns_pz/FrozenLake-v0", seed=3, params={"slip": (0.7, 0.15, 0.15)})
    model.rng = np.random.default_rng(11)
    kwargs = dict(iterations=40, depth=20, gamma=0.95, backend=backend)
    result = uct(model, 10, np.random.default_rng(12), **kwargs)
    assert result.action == 1
    np.testing.assert_array_equal(result.visits, [9, 13, 9, 9])
    np.testing.assert_array_equal(result.values, [0.0, 0.13902884615384614, 0.0, 0.0])
    assert result.stats == {"iterations": 40.0, "nodes": 29.0, "simulated_steps": 131.0}
    model.rng = np.random.default_rng(11)
    tree = uct_tree(model, 10, np.random.default_rng(12), **kwargs)
    assert tree.states[:8] == (10, 14, 6, 11, 11, 6, 13, 9)
    assert tree.parent[:8].tolist() == [-1, 0, 0, 0, 0, 0, 1, 0]
    assert tree.node_visits[:8].tolist() == [40, 8, 1, 0, 0, 6, 1, 5]


def in_tree_rewards_table() -> TabularOutcomes:
    """Action 0 pays 1 now then nothing; action 1 pays 0 now, then 0.5 or 3 (coin), then ends.

    With gamma=0.9: Q(0) = 1, Q(1) = 0.9 * (0.5 * 0.5 + 0.5 * 3) = 1.575: action 1 is optimal,
    although its first reward is lower.
    """
    stop = [(1.0, 4, 0.0, True), (0.0, 4, 0.0, True)]
    return table(
        [
            [
                [(1.0, 4, 1.0, True), (0.0, 4, 1.0, True)],
                [(0.5, 1, 0.0, False), (0.5, 2, 0.0, False)],
            ],
            [
                [(1.0, 4, 0.5, True), (0.0, 4, 0.5, True)],
                [(1.0, 4, 0.5, True), (0.0, 4, 0.5, True)],
            ],
            [
                [(1.0, 4, 3.0, True), (0.0, 4, 3.0, True)],
                [(1.0, 4, 3.0, True), (0.0, 4, 3.0, True)],
            ],
            [stop, stop],
            [stop, stop],
        ]
    )


@pytest.mark.parametrize("backend", BACKENDS)
def test_large_budget_finds_the_optimal_action_of_a_small_mdp(backend):
    """A greedy first reward misleads; with in-tree rewards backed up UCT finds VI's optimum."""
    outcomes = in_tree_rewards_table()
    _, q_values = value_iteration(outcomes, 0.9)
    assert q_values[0].argmax() == 1 and q_values[0, 0] == 1.0
    for seed in range(5):
        model = OutcomeTableModel(outcomes, 0, np.random.default_rng(seed))
        result = uct(
            model,
            0,
            np.random.default_rng(seed + 100),
            iterations=400,
            depth=0,
            gamma=0.9,
            backend=backend,
        )
        assert result.action == 1
        assert result.values[1] == pytest.approx(q_values[0, 1], abs=0.25)


@needs_numba
@pytest.mark.parametrize(
    ("env_id", "kwargs", "iterations", "depth", "gamma"),
    [
        ("ns_pz/FrozenLake-v0", {"params": {"slip": (0.6, 0.2, 0.2)}}, 200, 50, 0.99),
        (
            "ns_pz/CliffWalking-v0",
            {"goal_reward": 100.0, "params": {"slip": (0.7, 0.1, 0.1, 0.1)}},
            150,
            60,
            0.999,
        ),
        (  # a deterministic table: its compiled step still draws, as the Python one does
            "ns_pz/CliffWalking-v0",
            {"goal_reward": 100.0, "params": {"slip": (1.0, 0.0, 0.0, 0.0)}},
            150,
            60,
            0.999,
        ),
        ("ns_pz/BridgeSplit-v0", {"params": {"slip_left": (0.5, 0.25, 0.25)}}, 150, 30, 0.99),
        ("ns_pz/CartPole-v0", {"params": {"masspole": 0.7}}, 120, 200, 0.5),
        ("ns_pz/CartPole-v0", {"kinematics_integrator": "semi-implicit euler"}, 60, 100, 1.0),
    ],
)
def test_compiled_and_reference_paths_build_the_same_tree(env_id, kwargs, iterations, depth, gamma):
    """Same generators: the same tree node for node, and both generators left in the same state."""
    trees, after = [], []
    for backend in ("python", "compiled"):
        model = env_model(env_id, seed=4, **kwargs)
        model.rng = np.random.default_rng(21)
        rng = np.random.default_rng(22)
        trees.append(
            uct_tree(
                model,
                model.get_state(),
                rng,
                iterations=iterations,
                depth=depth,
                gamma=gamma,
                backend=backend,
            )
        )
        after.append((model.rng.random(), rng.random()))
    reference, compiled = trees
    assert reference.states == compiled.states
    for name in ("parent", "parent_action", "terminal", "node_visits", "visits", "q"):
        np.testing.assert_array_equal(getattr(reference, name), getattr(compiled, name), name)
    assert reference.simulated_steps == compiled.simulated_steps > iterations
    assert after[0] == after[1]


@needs_numba
def test_compiled_rollouts_match_the_reference_model_step_for_step():
    """Compiled rollout returns equal a Python loop over model.transition with the same draws."""
    from ns_pz.agents.search.compiled import kernels

    for env_id, kwargs in (
        ("ns_pz/CliffWalking-v0", {"params": {"slip": (0.5, 0.2, 0.2, 0.1)}}),
        ("ns_pz/CartPole-v0", {"params": {"length": 0.3}}),
    ):
        model = env_model(env_id, seed=1, **kwargs)
        compiled = compile_model(model, "compiled")
        root = model.get_state()
        model_rng, search_rng = np.random.default_rng(5), np.random.default_rng(6)
        returns, steps = kernels().repeated_rollouts(
            compiled.data,
            compiled.family.to_vector(root),
            30,
            compiled.num_actions,
            80,
            0.97,
            model_rng,
            search_rng,
        )
        model.rng, search = np.random.default_rng(5), np.random.default_rng(6)
        expected, total_steps = [], 0
        for _ in range(30):
            state, value, discount = root, 0.0, 1.0
            for _ in range(80):
                action = min(int(search.random() * compiled.num_actions), compiled.num_actions - 1)
                state, reward, done = model.transition(state, action)
                value += discount * reward
                discount *= 0.97
                total_steps += 1
                if done:
                    break
            expected.append(value)
        np.testing.assert_array_equal(returns, expected)
        assert steps == total_steps


class TouchyModel(OutcomeTableModel):
    """A table model that records every call that would move it (``set_state``, ``step``)."""

    def __init__(self, outcomes: TabularOutcomes, state: int, rng: np.random.Generator) -> None:
        super().__init__(outcomes, state, rng)
        self.moved = 0

    def set_state(self, state: int) -> None:
        """Record, then move."""
        self.moved += 1
        super().set_state(state)

    def step(self, action: int) -> tuple[int, float, bool]:
        """Record, then step."""
        self.moved += 1
        return super().step(action)


@pytest.mark.parametrize("backend", BACKENDS)
def test_uct_leaves_the_model_at_its_state(backend):
    """The search contract: a model sitting elsewhere than the root is neither moved nor reset.

    The model sits at state 4 and the search runs from state 0: a search that stepped the model
    (``set_state`` + ``step``) or put it at the root afterwards would leave it elsewhere.
    """
    outcomes = env_model("ns_pz/FrozenLake-v0", params={"slip": (0.6, 0.2, 0.2)}).outcomes
    model = TouchyModel(outcomes, 4, np.random.default_rng(0))
    model.moved = 0
    tree = uct_tree(model, 0, np.random.default_rng(1), iterations=50, depth=10, backend=backend)
    assert tree.states[0] == 0 and tree.num_nodes > 5
    assert model.get_state() == 4 and model.moved == 0


def ucb_table(gap: float) -> TabularOutcomes:
    """Root 0: action 0 pays 0 and ends, action 1 pays ``gap`` and ends."""
    return table([[[(1.0, 1, 0.0, True)], [(1.0, 1, gap, True)]], [[(1.0, 1, 0.0, True)]] * 2])


@pytest.mark.parametrize("backend", BACKENDS)
def test_ucb_uses_the_log_of_the_parent_visits(backend):
    """Four iterations, c = 1, terminal rewards 0 and 0.32 (no rollouts, no randomness).

    Both actions are tried once, then UCB takes action 1 (equal bonuses). At N = 3 with
    N(0) = 1 and N(1) = 2: sqrt(ln 3) = 1.0481 for action 0 against 0.32 + sqrt(ln 3 / 2) =
    1.0611 for action 1, so action 1 again: visits [1, 3]. With ln(N + 1) instead the scores
    would be 1.1774 and 1.1526, and action 0 taken: visits [2, 2].
    """
    model = OutcomeTableModel(ucb_table(0.32), 0, np.random.default_rng(0))
    options = {"iterations": 4, "depth": 0, "c": 1.0, "gamma": 1.0, "backend": backend}
    tree = uct_tree(model, 0, np.random.default_rng(5), **options)
    assert tree.visits[0].tolist() == [1, 3]
    np.testing.assert_array_equal(tree.q[0], [0.0, 0.32])


@pytest.mark.parametrize("backend", BACKENDS)
def test_final_rules_disagree_where_the_most_visited_action_is_not_the_best(backend):
    """Exploration c = 0, three iterations: action 1 pays 1 (greedy takes it again), then 0.

    Root: visits [1, 2], Q [0.6, 0.5]. ``final="value"`` plays 0, ``final="visits"`` plays 1.
    """
    for final, expected in (("value", 0), ("visits", 1)):
        model = OutcomeTableModel(coin_table(), 0, np.random.default_rng(2))
        options = {"iterations": 3, "depth": 0, "c": 0.0, "final": final, "backend": backend}
        result = uct(model, 0, np.random.default_rng(0), **options)
        assert result.visits.tolist() == [1, 2]
        np.testing.assert_array_equal(result.values, [0.6, 0.5])
        assert result.action == expected, final


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"iterations": 0}, ValueError, r"iterations=0 must be >= 1"),
        ({"iterations": 2.5}, TypeError, r"iterations=2.5 must be an integer"),
        ({"iterations": True}, TypeError, r"iterations=True must be an integer"),
        ({"depth": -1}, ValueError, r"depth=-1 must be >= 0"),
        ({"gamma": 1.5}, ValueError, r"gamma=1.5 must lie in \[0, 1\]"),
        ({"gamma": -0.1}, ValueError, r"gamma=-0.1 must lie in \[0, 1\]"),
        ({"gamma": float("nan")}, ValueError, r"gamma=nan must lie in \[0, 1\]"),
        ({"c": -1.0}, ValueError, r"c=-1.0 must be a finite number >= 0"),
        ({"c": "big"}, TypeError, r"c='big' must be a real number"),
        ({"final": "best"}, ValueError, r"final='best' is not a final-action rule"),
        ({"backend": "gpu"}, ValueError, r"backend='gpu' is not a backend"),
    ],
)
def test_bad_hyper_parameters_are_refused_with_their_value(kwargs, error, match):
    """Both the agent and the search function name the bad value and what is allowed."""
    with pytest.raises(error, match=match):
        MCTS(**kwargs)
    model = env_model("ns_pz/FrozenLake-v0")
    with pytest.raises(error, match=match):
        uct(model, 0, np.random.default_rng(0), **kwargs)


def test_compiled_backend_refuses_models_without_a_compiled_step():
    """backend='compiled' says why it cannot run; 'auto' falls back to the reference path."""

    class Opaque:
        action_space = ns_pz.make_gym("ns_pz/FrozenLake-v0").action_space
        rng = np.random.default_rng(0)

        def transition(self, state, action):
            return state, 0.0, True

    with pytest.raises(ValueError, match="backend='compiled' is not possible: Opaque has no"):
        uct(Opaque(), 0, np.random.default_rng(0), iterations=2, backend="compiled")
    # "auto" falls back to the reference path for it
    result = uct(Opaque(), 0, np.random.default_rng(0), iterations=4, depth=3)
    assert result.visits.sum() == 4


def test_non_discrete_action_space_is_refused():
    """UCT enumerates actions: a Box action space is refused."""

    class Continuous:
        from gymnasium import spaces

        action_space = spaces.Box(-1.0, 1.0, (1,))

    with pytest.raises(TypeError, match="Discrete"):
        uct(Continuous(), 0, np.random.default_rng(0), iterations=2)


def test_mcts_agent_plays_an_episode_reproducibly():
    """The agent runs in the evaluation loop; one seed gives one episode."""
    agent = MCTS(iterations=30, depth=20)
    assert isinstance(agent, SearchAgent) and agent.needs_model
    episodes = [
        run_episode(
            ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (1.0, 0.0, 0.0)}), agent, seed=2
        )
        for _ in range(2)
    ]
    assert episodes[0] == episodes[1]
    assert agent.last_result is not None and agent.last_result.visits.sum() == 30
    assert "iterations=30" in repr(agent)


def test_mcts_solves_the_deterministic_lake():
    """With exact transitions UCT finds the goal (VI's optimal return is 1)."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (1.0, 0.0, 0.0)})
    episode = run_episode(env, MCTS(iterations=200, depth=30, gamma=0.95), seed=0)
    assert episode.episode_return == 1.0


def test_importing_search_does_not_import_numba(tmp_path):
    """Compile time stays out of imports: numba loads on the first compiled search."""
    code = (
        "import sys, ns_pz, ns_pz.agents.search, ns_pz.agents.search.mcts;"
        "print('numba' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path
    ).stdout
    assert out.strip() == "False"


CACHE_SNIPPET = """
import json, os, sys
from pathlib import Path
import numpy as np, ns_pz, ns_pz.agents, ns_pz.envs
from ns_pz.agents.search import uct

def compiled_files():
    roots = {Path(m.__file__).parent for m in (ns_pz, ns_pz.envs, ns_pz.agents)}
    return {str(p): p.stat().st_mtime_ns for r in roots for p in r.rglob("*.nb[ic]")}

before = compiled_files()
env = ns_pz.make_gym("ns_pz/FrozenLake-v0"); env.reset(seed=0); model = env.planning_model()
uct(model, model.get_state(), np.random.default_rng(0), iterations=5, depth=5, backend="compiled")
after = compiled_files()
cached = sorted(p.name for p in Path(os.environ["NS_PZ_CACHE_DIR"]).rglob("*.nbi"))
print(json.dumps({"package": sorted(p for p in after if before.get(p) != after[p]),
                  "cache": cached}))
"""


@needs_numba
def test_compiled_code_is_cached_outside_the_package(tmp_path):
    """Numba's cache goes to NS_PZ_CACHE_DIR, never into the (installed) package folders."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["NS_PZ_CACHE_DIR"] = str(tmp_path / "cache")
    out = subprocess.run(
        [sys.executable, "-c", CACHE_SNIPPET],
        capture_output=True, text=True, check=True, cwd=tmp_path, env=env,
    )  # fmt: skip
    result = json.loads(out.stdout)
    assert result["package"] == []
    assert any(name.startswith("_kernels.") for name in result["cache"]), result
    assert (tmp_path / "cache" / "numba").is_dir()


@needs_numba
def test_cache_folder_order(monkeypatch, tmp_path):
    """NS_PZ_CACHE_DIR, then numba's NUMBA_CACHE_DIR (numba places it), then the user cache."""
    import numba
    from ns_pz.agents.search import numba_cache

    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    monkeypatch.delenv("NS_PZ_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if sys.platform.startswith("linux"):
        assert numba_cache.cache_dir() == tmp_path / "xdg" / "ns_pz" / "numba"
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba-own"))
    assert numba_cache.cache_dir() is None
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path / "mine"))
    assert numba_cache.cache_dir() == tmp_path / "mine" / "numba"


@pytest.mark.parametrize("gamma", [0.0, 1.0])
def test_gamma_bounds_are_allowed(gamma):
    """gamma=0 keeps only the first reward, gamma=1 sums them undiscounted."""
    model = OutcomeTableModel(two_step_table(), 0, np.random.default_rng(0))
    result = uct(model, 0, np.random.default_rng(0), iterations=6, depth=3, gamma=gamma)
    expected = 2.0 if gamma == 0.0 else 12.0
    assert result.values[1] == expected and math.isfinite(result.values[0])


@dataclass(frozen=True, slots=True)
class DriftParams(Params):
    """θ of the toy family below."""

    push: float = scalar(0.1, low=0.0, high=1.0)
    noise: float = scalar(0.05, low=0.0, high=1.0)


class DriftFamily(EnvFamily):
    """A point on a line pushed left or right with uniform noise; leaves [-1, 1] to end."""

    params_cls = DriftParams

    def __init__(self) -> None:
        from gymnasium import spaces

        self.observation_space = spaces.Box(-2.0, 2.0, (1,))
        self.action_space = spaces.Discrete(2)

    def initial_state(self, rng):
        """Start at the origin."""
        return (0.0,)

    def step(self, state, action, theta, rng):
        """Push, then one uniform draw of noise."""
        x = state[0] + (theta.push if action == 1 else -theta.push)
        x = x + theta.noise * (rng.random() - 0.5)
        return (x,), -abs(x), x < -1.0 or x > 1.0

    def observe(self, state):
        """The position."""
        return np.array(state, dtype=np.float32)


class DriftData(NamedTuple):
    """What the compiled drift step needs."""

    push: float
    noise: float


@needs_numba
def test_a_new_family_plugs_into_the_compiled_kernels(tmp_path):
    """The documented hook (NamedTuple, compiled step, two registrations) gives the Python tree."""
    import numba
    from ns_pz.agents.search import compiled

    @numba.njit(inline="always")
    def drift_step(data, state, out, action, rng):  # pragma: no cover - compiled
        x = state[0] + (data.push if action == 1 else -data.push)
        x = x + data.noise * (rng.random() - 0.5)
        out[0] = x
        return -abs(x), x < -1.0 or x > 1.0

    compiled.register_step(DriftData, drift_step)
    assert compiled.kernels_for(DriftData) is not compiled.kernels()  # never cached on disk
    compiled.register_compiled_family(
        DriftFamily,
        lambda model: DriftData(model.theta.push, model.theta.noise),
        lambda state: np.array(state, dtype=np.float64),
        lambda vector: (float(vector[0]),),
    )
    trees = []
    for backend in ("python", "compiled"):
        model = DriftFamily().planning_model(DriftParams(), (0.0,), np.random.default_rng(3))
        trees.append(
            uct_tree(
                model,
                (0.0,),
                np.random.default_rng(4),
                iterations=80,
                depth=30,
                gamma=0.9,
                backend=backend,
            )
        )
    assert trees[0].states == trees[1].states and len(trees[0].states) == 81
    np.testing.assert_array_equal(trees[0].q, trees[1].q)
    np.testing.assert_array_equal(trees[0].visits, trees[1].visits)
    # The on-disk cache stays readable by processes that cannot import this test module.
    code = (
        "import numpy as np, ns_pz; from ns_pz.agents.search import uct;"
        "env = ns_pz.make_gym('ns_pz/FrozenLake-v0'); env.reset(seed=0);"
        "m = env.planning_model();"
        "print(uct(m, 0, np.random.default_rng(0), iterations=5, backend='compiled').action)"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path, capture_output=True)


def test_a_compiled_tree_pickles_with_its_states_as_a_tuple():
    """Lazily converted node states pickle as the tuple they equal.

    CartPole's converter is a lambda, which pickle cannot name.
    """
    import pickle

    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    backend = "compiled" if numba_available() else "python"
    tree = uct_tree(
        model,
        model.get_state(),
        np.random.default_rng(0),
        iterations=20,
        depth=10,
        c=1.0,
        gamma=0.9,
        backend=backend,
    )
    again = pickle.loads(pickle.dumps(tree))
    assert isinstance(again.states, tuple) and again.states == tree.states
    np.testing.assert_array_equal(again.visits, tree.visits)


@needs_numba
def test_the_kernels_walk_known_edges_only_for_a_step_registered_deterministic():
    """CartPole's compiled step is registered deterministic, as its family says; tables draw."""
    import numba
    from ns_pz.agents.search._kernels import family_is_deterministic
    from ns_pz.agents.search.compiled import FIELDS, CartPoleData, TabularData
    from ns_pz.envs.cartpole import CartPoleFamily

    ask = numba.njit(lambda data: family_is_deterministic(data))
    cartpole = CartPoleData(9.8, 1.0, 0.1, 0.5, 10.0, 0.02, True, 2.4, 0.2)
    table = TabularData(np.zeros((1, 1, 1, FIELDS)))
    assert ask(cartpole) is True and CartPoleFamily.deterministic_step
    assert ask(table) is False


class _Draw:
    """A generator stand-in whose every draw is ``u``."""

    def __init__(self, u: float) -> None:
        self.u = u

    def random(self) -> float:
        return self.u


@needs_numba
def test_compiled_table_steps_pick_the_outcome_the_python_model_picks():
    """The tree's step scans, the rollout counts; both give the Python model's outcome.

    The tree's step scans the cumulative probabilities for the first above the draw, the
    rollout counts those at or below it. Every edge: a draw equal to a cumulative probability or
    one float either side of it, outcomes of zero probability, and a row whose probabilities
    sum below the draw (no table model accepts one; the kernels take the last outcome of
    positive probability, the Python model's rule when rounding leaves its total below).
    """
    from types import SimpleNamespace

    import numba
    from ns_pz.agents.search._kernels import family_step
    from ns_pz.agents.search.compiled import _tabular_data, kernels

    u = np.random.default_rng(7).random()  # the first draw of the model generator below
    below, above = np.nextafter(u, 0.0), np.nextafter(u, 1.0)
    rows = [
        [u, 0.0, 1.0 - u],
        [below, 0.0, 1.0 - below],
        [above, 0.0, 1.0 - above],
        [0.0, u, 1.0 - u],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.25 * u, 0.5 * u, 0.0],
    ]
    probs = np.array(rows)[:, None, :]  # one action
    shape = probs.shape
    states = len(rows)
    outcomes = TabularOutcomes(
        probs,
        (np.arange(states)[:, None, None] + np.arange(1, 4)) % (states - 1),  # one per outcome
        np.broadcast_to(np.arange(3.0), shape).copy(),  # the reward numbers the outcome
        np.ones(shape, np.bool_),  # every outcome ends the episode: a rollout is one step
    )
    valid = TabularOutcomes(*(part[:-1] for part in dataclasses.astuple(outcomes)[:4]))
    python_model = OutcomeTableModel(valid, 0, _Draw(u))  # type: ignore[arg-type]
    expected = [python_model.transition(s, 0) for s in range(states - 1)]
    expected.append((int(outcomes.next_states[-1, 0, 1]), 1.0, True))  # the last positive one
    assert [reward for _, reward, _ in expected] == [2, 2, 0, 2, 2, 0, 1]  # the edges are met
    data = _tabular_data(SimpleNamespace(outcomes=outcomes))
    step = numba.njit(lambda data, state, out, rng: family_step(data, state, out, 0, rng))
    for s, (next_state, reward, terminal) in enumerate(expected):
        state = np.array([float(s)])
        returns, steps = kernels().repeated_rollouts(
            data, state, 1, 1, 5, 1.0, np.random.default_rng(7), np.random.default_rng(0)
        )
        assert (returns[0], steps) == (reward, 1), s
        out = np.empty(1)
        assert step(data, state, out, np.random.default_rng(7)) == (reward, terminal), s
        assert out[0] == next_state, s


@needs_numba
@pytest.mark.parametrize(
    ("row", "bad"),
    [([0.5, np.nan, 0.5], "nan"), ([0.5, -0.25, 0.75], "-0.25"), ([0.0, 0.0, 0.0], "0.0")],
)
def test_a_compiled_table_refuses_a_row_the_python_model_could_not_draw_from(row, bad):
    """A NaN, a negative probability or a row without a positive one is refused, named.

    The kernels would pick an outcome there that no draw gives in the Python model.
    """
    from types import SimpleNamespace

    from ns_pz.agents.search.compiled import _tabular_data

    probs = np.array([[[1.0, 0.0, 0.0]], [row]])
    shape = probs.shape
    outcomes = TabularOutcomes(
        probs, np.zeros(shape, np.int64), np.zeros(shape), np.zeros(shape, np.bool_)
    )
    with pytest.raises(ValueError, match=rf"outcomes\.probs\[1, 0\] = .*{bad}"):
        _tabular_data(SimpleNamespace(outcomes=outcomes))


@needs_numba
def test_a_compiled_table_refuses_arrays_of_other_shapes():
    """The kernels read the four arrays unchecked: one of another shape is named first."""
    from types import SimpleNamespace

    from ns_pz.agents.search.compiled import _tabular_data

    shape = (2, 1, 1)
    outcomes = TabularOutcomes(
        np.ones(shape), np.zeros(shape, np.int64), np.zeros((2, 1)), np.zeros(shape, np.bool_)
    )
    with pytest.raises(ValueError, match=r"outcomes\.rewards has shape \(2, 1\), probs has"):
        _tabular_data(SimpleNamespace(outcomes=outcomes))


@needs_numba
def test_a_compiled_table_holds_the_python_models_running_totals():
    """The cumulative probabilities are the Python model's running totals, bit for bit.

    Summed outcome by outcome, as its loop sums; infinite from the last outcome of positive
    probability on. Next states out of range are refused.
    """
    import itertools
    from types import SimpleNamespace

    from ns_pz.agents.search.compiled import CUMULATIVE, _tabular_data

    rng = np.random.default_rng(11)
    probs = rng.random((6, 3, 7)).astype(np.float32) * (rng.random((6, 3, 7)) < 0.7)
    probs[:, :, 0] += 1e-3  # no row without a positive entry
    probs /= probs.sum(axis=2, keepdims=True)
    shape = probs.shape
    outcomes = TabularOutcomes(
        probs, rng.integers(6, size=shape), np.zeros(shape), np.zeros(shape, np.bool_)
    )
    table = _tabular_data(SimpleNamespace(outcomes=outcomes)).table
    for s, a in itertools.product(range(6), range(3)):
        row = probs[s, a].tolist()
        last = max(k for k, p in enumerate(row) if p > 0.0)
        totals = list(itertools.accumulate(row))  # 0.0 + row[0] is row[0]: the model's loop
        assert table[s, a, :last, CUMULATIVE].tolist() == totals[:last]
        assert np.isinf(table[s, a, last:, CUMULATIVE]).all()
    bad = TabularOutcomes(probs, np.full(shape, 6), np.zeros(shape), np.zeros(shape, np.bool_))
    with pytest.raises(ValueError, match=r"outcomes\.next_states must lie in \[0, 6\)"):
        _tabular_data(SimpleNamespace(outcomes=bad))
