"""AlphaZero: PUCT against a hand-worked tree, the loss, and learning on θ_0."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces
from ns_pz.agents import evaluate
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.puct import PUCTSettings, puct, puct_tree

import ns_pz

FROZEN_LAKE = {"slip": [0.7, 0.15, 0.15]}


class ToyModel:
    """Deterministic toy model.

    0 -a0-> 1 (r 1); 0 -a1-> 2 (r 0, end); 1 -a0-> 3 (r 0); 1 -a1-> 4 (r 3, end).
    """

    action_space = spaces.Discrete(2)
    EDGES = {
        (0, 0): (1, 1.0, False),
        (0, 1): (2, 0.0, True),
        (1, 0): (3, 0.0, False),
        (1, 1): (4, 3.0, True),
        (3, 0): (3, 0.0, False),
        (3, 1): (3, 0.0, False),
    }

    def transition(self, state, action):
        """The one outcome of (state, action)."""
        return self.EDGES[(state, action)]


VALUES = {0: 0.0, 1: 2.0, 3: -4.0}


def _evaluate(state):
    return np.array([0.6, 0.4]), VALUES[state]


def _toy_tree(**settings):
    """PUCT on the toy model with γ = 0.5 and ``settings``."""
    puct_settings = PUCTSettings(gamma=0.5, **settings)
    return puct_tree(ToyModel(), 0, np.random.default_rng(0), _evaluate, puct_settings)


def test_puct_matches_a_hand_worked_tree():
    """C = 1, γ = 0.5, priors (0.6, 0.4), four simulations, worked out by hand.

    1. root: scores (0.6, 0.4) -> a0; new node 1 (v = 2); G = 1 + 0.5*2 = 2.   Q0 = 2
    2. root: (2 + 0.6√2/2, 0 + 0.4√2) -> a0; node 1: (2.6, 2.4) -> a0; new node 3 (v = -4);
       node 1: G = 0 + 0.5*(-4) = -2; root: G = 1 + 0.5*(-2) = 0.                  Q0 = 1
    3. root: (1 + 0.6√3/3, 0.4√3) -> a0; node 1: (-2 + 0.6√2/2, 2 + 0.4√2) -> a1; new
       terminal node 4 (value 0); node 1: G = 3; root: G = 1 + 1.5 = 2.5.           Q0 = 1.5
    4. root: (1.5 + 0.3, 0.8) -> a0; node 1: (-2 + 0.6√3/2, 3 + 0.4√3/2) -> a1; node 4 is
       terminal: leaf 0; node 1: G = 3; root: G = 2.5.                             Q0 = 1.75
    """
    tree = _toy_tree(iterations=4, depth=5, c=1.0)
    np.testing.assert_array_equal(tree.visits, [4, 0])
    np.testing.assert_allclose(tree.q, [1.75, 0.0])
    assert (tree.num_nodes, tree.simulated_steps) == (4, 7)
    assert tree.value_target() == pytest.approx(1.75)
    np.testing.assert_allclose(tree.policy_target(1.0), [1.0, 0.0])


def test_normalised_q_matches_a_hand_worked_tree():
    """The same tree with Q min-max scaled by the values backed up so far (MuZero's rule).

    1. no bounds yet: as before, a0, Q0 = 2; bounds [2, 2] (equal: no scaling).
    2. a0, a0 as before; new node 3; node 1 Q = -2, root Q0 = 1; bounds [-2, 2].
    3. root: scaled Q (0.75, 0.5): (0.75 + 0.6√3/3, 0.5 + 0.4√3) -> a1; terminal node 2;
       root Q1 = 0.
    4. root: (0.75 + 0.6·2/4, 0.5 + 0.4·2/2) -> a0; node 1: scaled (0, 1) -> a1: terminal
       node 4, node 1 Q1 = 3; root G = 2.5, Q0 = 4.5 / 3 = 1.5.
    """
    tree = _toy_tree(iterations=4, depth=5, c=1.0, normalise_q=True)
    np.testing.assert_array_equal(tree.visits, [3, 1])
    np.testing.assert_allclose(tree.q, [1.5, 0.0])
    assert (tree.num_nodes, tree.simulated_steps) == (5, 6)


def test_puct_depth_limit_takes_the_node_value():
    """With depth 0 a simulation stops at the first existing node and backs up its value."""
    tree = _toy_tree(iterations=3, depth=0, c=1.0)
    np.testing.assert_array_equal(tree.visits, [3, 0])
    np.testing.assert_allclose(tree.q, [2.0, 0.0])
    assert (tree.num_nodes, tree.simulated_steps) == (2, 3)


def test_policy_target_temperature():
    """Policy target temperature."""
    tree = _toy_tree(iterations=4, depth=5, c=10.0)
    visits = tree.visits.astype(float)
    np.testing.assert_allclose(tree.policy_target(1.0), visits / visits.sum())
    squared = visits**2 / (visits**2).sum()
    np.testing.assert_allclose(tree.policy_target(0.5), squared)


def test_root_noise_comes_from_the_search_generator():
    """Root noise comes from the search generator."""
    settings = PUCTSettings(20, 5, 1.0, 0.5, dirichlet_alpha=0.3, noise=0.75)
    first = puct(ToyModel(), 0, np.random.default_rng(1), _evaluate, settings)
    again = puct(ToyModel(), 0, np.random.default_rng(1), _evaluate, settings)
    np.testing.assert_array_equal(first.visits, again.visits)


def _policy_value_learner(dead_unit: bool, dtype=np.float64):
    """A learner on 5 features, trunk (8, 6), 3 actions; optionally a unit no input activates."""
    from ns_pz.agents.learning.alphazero import PolicyValueLearner

    args = AlphaZeroArgs(learning_rate=1e-2, weight_decay=1e-3)
    learner = PolicyValueLearner(5, (8, 6), 3, args, np.random.default_rng(0), dtype)
    if dead_unit:  # unit 2 of the second trunk layer: inputs >= 0 and a large negative bias
        w, b = learner.mlp.layers[1]
        w[:, 2], b[2] = np.abs(w[:, 2]) * -1.0, -100.0
    return learner


def _batch(rng, size=7):
    x = np.abs(rng.normal(size=(size, 5)))
    pi = rng.dirichlet(np.ones(3), size=size)
    return x, pi, rng.normal(size=size)


@pytest.mark.parametrize("dead_unit", [False, True])
def test_policy_value_steps_match_torch_autograd_and_adam(dead_unit):
    """Loss, gradient and three Adam steps (weight decay on) equal torch's in float64.

    Torch's side is the textbook network: a ``Linear``/ReLU trunk, ReLU on its output, a policy
    and a value ``Linear`` head, ``MSE(v, z) + CE(π, log_softmax(logits))`` (the cross-entropy
    on the logits, not on softmax outputs as NS-Gym), ``backward`` and ``torch.optim.Adam``.
    With ``dead_unit`` one trunk unit is off for the whole batch (its incoming weights then
    change by weight decay alone).
    """
    torch = pytest.importorskip("torch")
    learner = _policy_value_learner(dead_unit)
    exported = learner.export()
    tensors = {
        k: torch.tensor(v, dtype=torch.float64, requires_grad=True) for k, v in exported.items()
    }
    names = sorted(tensors)
    optimizer = torch.optim.Adam([tensors[k] for k in names], lr=1e-2, weight_decay=1e-3)
    x, pi, z = _batch(np.random.default_rng(1))
    xt, pit, zt = (torch.from_numpy(a) for a in (x, pi, z))

    def torch_loss():
        h = xt
        for i in range(2):
            h = torch.relu(h @ tensors[f"trunk.{i}.weight"].T + tensors[f"trunk.{i}.bias"])
        logits = h @ tensors["policy.0.weight"].T + tensors["policy.0.bias"]
        values = (h @ tensors["value.0.weight"].T + tensors["value.0.bias"]).squeeze(1)
        cross_entropy = -(pit * torch.log_softmax(logits, dim=1)).sum(dim=1).mean()
        return torch.nn.functional.mse_loss(values, zt) + cross_entropy

    for _ in range(3):
        loss = torch_loss()
        optimizer.zero_grad()
        loss.backward()
        assert learner.gradient_step(x, pi, z) == pytest.approx(loss.item(), rel=1e-12)
        optimizer.step()
        for name, value in learner.export().items():
            expected = tensors[name].detach().numpy()
            np.testing.assert_allclose(value, expected, rtol=1e-9, atol=1e-14, err_msg=name)
    if dead_unit:  # no gradient reached the dead unit's incoming weights but weight decay's
        assert learner.export()["trunk.1.bias"][2] < -99.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"widths": [4]}, r"widths=\[4\] must list at least two widths"),
        ({"widths": [4, 0, 2]}, r"widths=\[4, 0, 2\] must list at least two widths, each >= 1"),
        ({"params": np.zeros(3)}, r"params has shape \(3,\); widths \[4, 2\] need \(10,\)"),
        ({"dtype": np.int64}, "dtype=.*int64.* is not allowed; allowed: float32, float64"),
    ],
)
def test_a_learner_refuses_bad_shapes_and_dtypes(kwargs, match):
    """Widths, the flat parameters' length and the dtype are checked, naming the value."""
    from ns_pz.agents.learning.mlp import MLPLearner

    given = {"widths": [4, 2], "params": np.zeros(10), "dtype": np.float64, **kwargs}
    with pytest.raises(ValueError, match=match):
        MLPLearner(given["widths"], given["params"], 1e-3, 0.0, given["dtype"])


def test_float32_leaves_a_dead_unit_out_of_the_backward_product_and_agrees_with_float64():
    """Three float32 steps with a unit the batch never activates equal float64's to 1e-5.

    float32 takes the path that leaves the dead unit's outgoing weights out of the backward
    product (float64 takes the plain product); the masked gradient makes the two the same.
    """
    x, pi, z = _batch(np.random.default_rng(1))
    wide = _policy_value_learner(True, np.float64)
    narrow = _policy_value_learner(True, np.float32)
    narrow.mlp.params[:] = wide.mlp.params
    for _ in range(3):
        wide.gradient_step(x, pi, z)
        narrow.gradient_step(x.astype(np.float32), pi, z)
    np.testing.assert_allclose(narrow.mlp.params, wide.mlp.params, rtol=1e-5, atol=1e-6)
    assert narrow.mlp.params.dtype == np.float32


def test_a_float32_learner_flushes_subnormals_to_zero():
    """Subnormal weights (weight decay's endpoint for unused inputs) become 0 after a step.

    Left in, they make every product they enter tens of times slower; torch keeps them.
    """
    learner = _policy_value_learner(False, np.float32)
    learner.mlp.params[:5] = np.float32(1e-40)  # input 0's weights to the first 5 units
    x, pi, z = _batch(np.random.default_rng(1))
    x[:, 0] = 0.0  # input 0 unused: its weights' gradient is weight decay's alone (subnormal)
    learner.gradient_step(x.astype(np.float32), pi, z)
    tiny = np.finfo(np.float32).tiny
    for state in (learner.mlp.params, learner.mlp.m, learner.mlp.v):
        assert state.dtype == np.float32
        assert not np.any((state != 0) & (np.abs(state) < tiny))
    assert learner.export()["trunk.0.weight"].dtype == np.float32


@pytest.fixture
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))


@pytest.mark.usefixtures("_tmp_cache")
def test_alphazero_learns_frozen_lake_at_theta0():
    """40 self-play episodes (seconds): PUCT with the trained net far above random on θ_0."""

    def make():
        return ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE, max_episode_steps=100)

    agent = agent_entry("alphazero").make(make(), {"episodes": 40, "iterations": 50})
    learned = np.mean([e.episode_return for e in evaluate(make, agent, range(30))])
    random = np.mean(
        [e.episode_return for e in evaluate(make, RandomAgent(make().action_space), range(30))]
    )
    assert random < 0.1 and learned > 0.4


def test_bad_args_are_refused():
    """Bad args are refused."""
    with pytest.raises(ValueError, match="value_target='mc' is not allowed"):
        AlphaZeroArgs(value_target="mc")
    with pytest.raises(ValueError, match="episodes=0 must be >= 1"):
        AlphaZeroArgs(episodes=0)


def _random_function(space, seed):
    """A fixed random policy/value network over ``space``."""
    from ns_pz.agents.learning.puct import PolicyValueFunction

    rng = np.random.default_rng(seed)
    n = int(space.n)
    weights = {
        "trunk.0.weight": rng.normal(size=(16, n)),
        "trunk.0.bias": rng.normal(size=16),
        "policy.0.weight": rng.normal(size=(4, 16)),
        "policy.0.bias": rng.normal(size=4),
        "value.0.weight": rng.normal(size=(1, 16)),
        "value.0.bias": rng.normal(size=1),
    }
    return PolicyValueFunction(weights, space)


@pytest.mark.parametrize("normalise_q", [False, True])
@pytest.mark.parametrize(
    ("env_id", "slip", "noise"),
    [
        ("ns_pz/FrozenLake-v0", [0.7, 0.15, 0.15], 0.0),
        ("ns_pz/CliffWalking-v0", [0.6, 0.2, 0.1, 0.1], 0.75),
        ("ns_pz/Bridge-v0", [0.7, 0.15, 0.15], 0.0),
    ],
)
def test_compiled_puct_builds_the_python_tree(env_id, slip, noise, normalise_q):
    """Same generators, same tree: compiled and Python PUCT agree on every root statistic."""
    import copy

    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import TabularEvaluation, model_evaluation

    env = ns_pz.make_gym(env_id, params={"slip": slip})
    env.reset(seed=3)
    function = _random_function(env.family.observation_space, 3)
    settings = PUCTSettings(
        60, 10, 1.3, 0.95, dirichlet_alpha=0.5, noise=noise, normalise_q=normalise_q
    )
    for seed in range(3):
        model = env.planning_model()
        twin = copy.deepcopy(model)
        evaluate = model_evaluation(function, model)
        assert isinstance(evaluate, TabularEvaluation)
        state = model.get_state()
        python = puct_tree(model, state, np.random.default_rng(seed), evaluate, settings, "python")
        compiled = puct_tree(
            twin, state, np.random.default_rng(seed), evaluate, settings, "compiled"
        )
        np.testing.assert_array_equal(compiled.visits, python.visits)
        np.testing.assert_array_equal(compiled.q, python.q)
        assert (compiled.num_nodes, compiled.simulated_steps) == (
            python.num_nodes,
            python.simulated_steps,
        )
        _, _, terminated, truncated, _ = env.step(int(np.argmax(python.visits)))
        if terminated or truncated:
            env.reset(seed=seed)


def _random_cartpole_function(seed=0, trunk=(8,), policy=(), value=(), actions=2):
    """A random policy/value network over CartPole's 4 floats (hidden head layers optional)."""
    from ns_pz.agents.learning.puct import PolicyValueFunction

    rng = np.random.default_rng(seed)
    weights = {}
    for prefix, sizes in (
        ("trunk", (4, *trunk)),
        ("policy", (trunk[-1], *policy, actions)),
        ("value", (trunk[-1], *value, 1)),
    ):
        for i in range(len(sizes) - 1):
            scale = 1.0 / np.sqrt(sizes[i])
            weights[f"{prefix}.{i}.weight"] = rng.normal(size=(sizes[i + 1], sizes[i])) * scale
            weights[f"{prefix}.{i}.bias"] = rng.normal(size=sizes[i + 1]) * 0.5
    space = ns_pz.make_gym("ns_pz/CartPole-v0").family.observation_space
    return PolicyValueFunction(weights, space)


# a start state, and states near the edges, where simulations reach terminal states
CARTPOLE_STATES = [None, (0.0, 0.3, 0.15, 0.4), (2.2, 0.8, -0.05, -0.2)]


@pytest.mark.parametrize("normalise_q", [False, True])
@pytest.mark.parametrize(("noise", "depth"), [(0.0, 100), (0.5, 3), (0.0, 0)])
@pytest.mark.parametrize("state", CARTPOLE_STATES)
def test_compiled_puct_on_cartpole_builds_the_python_tree(state, noise, depth, normalise_q):
    """The network inside the kernel: compiled and Python PUCT agree on every root statistic.

    Depth 3 binds (the simulations stop at existing nodes three levels down), depth 0 keeps
    every simulation at the root's children.
    """
    import copy

    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import VectorEvaluation, model_evaluation

    env = ns_pz.make_gym("ns_pz/CartPole-v0", params={"masspole": 0.5})
    env.reset(seed=2)
    function = _random_cartpole_function(1, trunk=(16, 16))
    settings = PUCTSettings(
        150, depth, 1.3, 0.97, dirichlet_alpha=0.5, noise=noise, normalise_q=normalise_q
    )
    model = env.planning_model()
    root = model.get_state() if state is None else state
    evaluate = model_evaluation(function, model)
    assert isinstance(evaluate, VectorEvaluation)
    for seed in range(3):
        twin = copy.deepcopy(model)
        python = puct_tree(model, root, np.random.default_rng(seed), evaluate, settings, "python")
        compiled = puct_tree(
            twin, root, np.random.default_rng(seed), evaluate, settings, "compiled"
        )
        np.testing.assert_array_equal(compiled.visits, python.visits)
        np.testing.assert_array_equal(compiled.q, python.q)
        np.testing.assert_array_equal(compiled.priors, python.priors)
        assert (compiled.num_nodes, compiled.simulated_steps) == (
            python.num_nodes,
            python.simulated_steps,
        )
        assert python.num_nodes > (1 if depth == 0 else 10)


@pytest.mark.parametrize("noise", [0.0, 0.5])
def test_searches_along_an_episode_reuse_evaluations_and_build_the_python_trees(noise):
    """The network's memo of its last search: found again along an episode, never a change.

    Each decision searches the state the last one's action led to, so much of the new tree was
    in the last one; those nodes' evaluations come from the memo (``remembered``), and every
    tree is still the Python path's (which has no memo).
    """
    import copy

    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import model_evaluation

    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=4)
    function = _random_cartpole_function(2, trunk=(16, 16))
    settings = PUCTSettings(120, 50, 1.4, 1.0, dirichlet_alpha=0.5, noise=noise)
    remembered = []
    for step in range(12):
        model = env.planning_model()
        evaluate = model_evaluation(function, model)
        root = model.get_state()
        python = puct_tree(
            copy.deepcopy(model), root, np.random.default_rng(step), evaluate, settings, "python"
        )
        compiled = puct_tree(model, root, np.random.default_rng(step), evaluate, settings)
        np.testing.assert_array_equal(compiled.visits, python.visits)
        np.testing.assert_array_equal(compiled.q, python.q)
        assert (compiled.num_nodes, compiled.simulated_steps) == (
            python.num_nodes,
            python.simulated_steps,
        )
        inputs, priors, values = function.search_memo
        assert len(inputs) == len(priors) == len(values) <= compiled.num_nodes - 1
        remembered.append(compiled.remembered)
        _, _, terminated, truncated, _ = env.step(int(np.argmax(python.visits)))
        if terminated or truncated:
            break
    assert len(remembered) >= 6 and remembered[0] == 0
    assert sum(remembered) >= 10, remembered


def test_a_fresh_network_remembers_nothing_of_another():
    """The memo belongs to one network: another (other weights) evaluates every node itself."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import model_evaluation

    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    settings = PUCTSettings(60, 20, 1.4, 1.0)
    first = _random_cartpole_function(0, trunk=(8,))
    root = model.get_state()
    puct_tree(model, root, np.random.default_rng(0), model_evaluation(first, model), settings)
    evaluated = len(first.search_memo[0])
    again = puct_tree(
        model, root, np.random.default_rng(0), model_evaluation(first, model), settings
    )
    other = _random_cartpole_function(1, trunk=(8,))
    fresh = puct_tree(
        model, root, np.random.default_rng(0), model_evaluation(other, model), settings
    )
    python = puct_tree(
        model, root, np.random.default_rng(0), model_evaluation(other, model), settings, "python"
    )
    assert again.remembered == evaluated > 0  # the same search: every evaluation found
    assert fresh.remembered == 0 and other.search_memo is not None
    np.testing.assert_array_equal(fresh.visits, python.visits)
    np.testing.assert_array_equal(fresh.q, python.q)


def test_the_memo_index_finds_each_input_bit_for_bit():
    """Rows found where they are, duplicates at their first row, anything else not at all."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning import _puct_kernels as kernels

    rng = np.random.default_rng(0)
    keys = rng.normal(size=(300, 4)).astype(np.float32).astype(np.float64)
    keys[7] = keys[3]  # a duplicate
    keys[8] = 0.0
    bits = keys.view(np.int64)
    slots = kernels._memo_slots(bits)
    assert len(slots) >= 2 * len(keys) and len(slots) & (len(slots) - 1) == 0
    for i in range(len(keys)):
        assert kernels._memo_find(slots, bits, bits[i]) == (3 if i == 7 else i)
    negative_zero = np.full(4, -0.0)  # equal to row 8 as numbers, not as bits
    for probe in (negative_zero, np.nextafter(keys[5], np.inf), rng.normal(size=4)):
        assert kernels._memo_find(slots, bits, probe.view(np.int64)) == -1
    empty = np.empty((0, 4)).view(np.int64)
    assert kernels._memo_find(kernels._memo_slots(empty), empty, bits[0]) == -1


def test_auto_searches_cartpole_compiled():
    """backend='auto' takes the kernel for CartPole with a network: the same tree, faster."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning import puct as puct_module
    from ns_pz.agents.learning.puct import model_evaluation

    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    evaluate = model_evaluation(_random_cartpole_function(), model)
    assert puct_module._compiled(model, evaluate, "auto") is not None
    assert puct_module._compiled(model, evaluate, "python") is None


@pytest.mark.parametrize(
    ("trunk", "policy", "value"), [((8,), (), ()), ((128, 128), (), ()), ((16, 8), (5,), (7, 3))]
)
def test_the_compiled_forward_pass_is_numpys(trunk, policy, value):
    """The kernel's forward pass agrees with NumpyMLP's to rounding (1e-12 relative)."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning.features import features
    from ns_pz.agents.learning.puct import VectorEvaluation

    function = _random_cartpole_function(3, trunk, policy, value)
    space = function.space
    evaluate = VectorEvaluation(function, lambda state: np.array(state, dtype=np.float32))
    rng = np.random.default_rng(0)
    for state in rng.normal(size=(20, 4)) * [1.0, 2.0, 0.2, 2.0]:
        priors, v = evaluate(tuple(state))
        expected_priors, expected_v = function(features(space, np.float32(state)))
        np.testing.assert_allclose(priors, expected_priors, rtol=1e-12, atol=0)
        np.testing.assert_allclose(v, expected_v, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize(
    ("trunk", "policy_head", "value_head", "actions"),
    [
        ((128, 128), (), (7,), 2),  # the heads apart: the value head has two layers
        ((40, 70), (), (), 2),  # both heads in one pass, from here to 3 actions
        ((128, 128), (), (), 2),
        ((32,), (), (), 1),
        ((33,), (), (), 3),
        ((33,), (), (), 4),  # apart again: four actions
        ((16,), (5,), (), 3),  # apart: the policy head has two layers
    ],
)
def test_the_compiled_forward_pass_sums_each_output_in_input_order_bit_for_bit(
    trunk, policy_head, value_head, actions
):
    """Each dense output is ``((0 + x_0 w_0) + x_1 w_1) + ...`` then the bias, exactly.

    So skipping zero inputs (ReLU'd units, a state component of exactly 0) changes no bit, nor
    does summing the outputs 32 at a time in vector registers and the rest four at a time (40
    and 70 outputs: one and two blocks and a rest; a head's 7, 2 and 1: a rest only), nor
    computing both one-layer heads in one pass: the logits and the value equal this order-exact
    numpy reference's, with and without zeros (the priors are the kernel's softmax of them).
    """
    pytest.importorskip("numba")
    from ns_pz.agents.learning._puct_kernels import _softmax_into, network

    function = _random_cartpole_function(5, trunk, policy_head, value_head, actions)
    weights, layout, parts = function.packed()
    heads = parts[0] + parts[1]

    def dense(x, row, relu):
        at, inputs, outputs, bias = row
        matrix = weights[at : at + inputs * outputs].reshape(inputs, outputs)
        acc = np.zeros(outputs)
        for i in range(inputs):
            acc = acc + x[i] * matrix[i]
        out = acc + weights[bias : bias + outputs]
        return np.where(out > 0.0, out, 0.0) if relu else out

    def layers(x, rows, relu_last=False):
        for k, row in enumerate(rows):
            x = dense(x, row, relu_last or k < len(rows) - 1)
        return x

    rng = np.random.default_rng(1)
    states = rng.normal(size=(30, 4)) * rng.choice([0.0, 1.0], size=(30, 4))
    zeros = 0
    for state in states:
        x = np.float64(np.float32(state))
        h = layers(x, layout[: parts[0]], relu_last=True)
        zeros += int(np.sum(h == 0.0))
        expected_priors = np.empty(actions)
        _softmax_into(layers(h, layout[parts[0] : heads]), expected_priors)
        expected_value = layers(h, layout[heads:])[0]
        priors, value = network(weights, layout, parts, x)
        assert value == expected_value
        np.testing.assert_array_equal(priors, expected_priors)
    assert zeros > 30 * min(trunk) / 4  # many switched-off units were skipped


def test_packed_weights_start_on_a_cache_line_and_each_matrix_on_eight_floats():
    """Where the compiled forward pass's vector loads are fastest; a pickled copy packs again."""
    import pickle

    function = _random_cartpole_function(2, (40, 70), (5,), ())
    weights, layout, _ = function.packed()
    assert weights.ctypes.data % 64 == 0
    assert all(start % 8 == 0 for start in layout[:, 0])
    mlps = (function.trunk, function.policy, function.value)
    layers = [layer for mlp in mlps for layer in mlp.layers]
    for (w, b), (start, inputs, outputs, bias) in zip(layers, layout, strict=True):
        assert (inputs, outputs) == w.shape and bias == start + w.size
        np.testing.assert_array_equal(weights[start:bias], w.ravel())
        np.testing.assert_array_equal(weights[bias : bias + outputs], b)
    assert function.packed()[0] is weights  # built once
    copy = pickle.loads(pickle.dumps(function))
    again, layout_again, _ = copy.packed()
    assert again.ctypes.data % 64 == 0
    np.testing.assert_array_equal(again, weights)
    np.testing.assert_array_equal(layout_again, layout)


def test_compiled_puct_refuses_what_it_cannot_run():
    """backend='compiled' names why: a plain function on CartPole, another observation."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import VectorEvaluation

    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    function = _random_cartpole_function()
    settings = PUCTSettings(5, 5, 1.0, 1.0)
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="on CartPoleFamily needs a VectorEvaluation"):
        puct_tree(model, model.get_state(), rng, function, settings, "compiled")
    stranger = VectorEvaluation(function, lambda state: np.array(state, dtype=np.float32))
    with pytest.raises(ValueError, match="other than CartPoleFamily.observe"):
        puct_tree(model, model.get_state(), rng, stranger, settings, "compiled")
    # "auto" falls back to the Python path for both
    for fallback in (function, stranger):
        tree = puct_tree(model, model.get_state(), rng, fallback, settings)
        assert tree.visits.sum() == 5


def test_compiled_puct_on_a_grid_needs_a_tabulated_network():
    """A tabular model with a VectorEvaluation: backend='compiled' asks for the table."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning.puct import VectorEvaluation

    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    env.reset(seed=0)
    model = env.planning_model()
    function = _random_function(env.family.observation_space, 0)
    evaluate = VectorEvaluation(function, model.family.observe)
    with pytest.raises(ValueError, match="on a tabular model needs a TabularEvaluation"):
        puct_tree(
            model, 0, np.random.default_rng(0), evaluate, PUCTSettings(5, 5, 1.0, 1.0), "compiled"
        )


def test_priors_of_the_wrong_length_are_refused():
    """An evaluation with three priors for a model of two actions."""
    with pytest.raises(ValueError, match="evaluate gave 3 priors for 2 actions"):
        puct_tree(
            ToyModel(),
            0,
            np.random.default_rng(0),
            lambda state: (np.full(3, 1 / 3), 0.0),
            PUCTSettings(5, 5, 1.0, 1.0),
        )


def test_normalise_q_must_be_a_bool():
    """The string "false" would have switched normalisation on."""
    with pytest.raises(TypeError, match="normalise_q='false' must be a bool"):
        AlphaZeroArgs(normalise_q="false")


class RecordingModel(ToyModel):
    """The toy model, recording every (state, action) a search simulates."""

    def __init__(self):
        self.calls = []

    def transition(self, state, action):
        """Record, then the toy model's outcome."""
        self.calls.append((state, action))
        return super().transition(state, action)


def test_root_noise_is_mixed_into_the_root_priors_and_nowhere_else():
    """Priors (1, 0) everywhere and c huge: selection follows the priors exactly.

    The root's priors are (1 - ε)(1, 0) + ε·Dir(α), the Dirichlet being the search generator's
    first draw, so the root tries action 1 too; every other node keeps the network's (1, 0) and
    only ever takes action 0.
    """
    model = RecordingModel()
    settings = PUCTSettings(20, 5, 1e6, 0.5, dirichlet_alpha=1.0, noise=0.5)
    tree = puct_tree(
        model, 0, np.random.default_rng(4), lambda s: (np.array([1.0, 0.0]), 0.0), settings
    )
    noise = np.random.default_rng(4).dirichlet([1.0, 1.0])
    np.testing.assert_allclose(tree.priors, 0.5 * np.array([1.0, 0.0]) + 0.5 * noise)
    assert tree.visits[1] > 0  # the noise reached the root's selection
    assert {action for state, action in model.calls if state != 0} == {0}


@pytest.mark.parametrize("backend", ["python", "compiled"])
def test_unvisited_root_actions_start_at_the_roots_value(backend):
    """First-play value: after one simulation the three untried actions have Q = v(root)."""
    from ns_pz.agents.learning.puct import TabularEvaluation

    if backend == "compiled":
        pytest.importorskip("numba")
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    env.reset(seed=0)
    model = env.planning_model()
    evaluate = TabularEvaluation(np.full((16, 4), 0.25), np.full(16, 0.7))
    tree = puct_tree(
        model, 0, np.random.default_rng(0), evaluate, PUCTSettings(1, 5, 1.0, 0.9), backend
    )
    assert tree.visits.sum() == 1
    np.testing.assert_allclose(tree.q[tree.visits == 0], 0.7)


def test_a_move_is_drawn_from_the_visits_at_the_temperature():
    """Visits (1, 3, 0, 6) at T = 0.5: policy N² / ΣN² = (1, 9, 0, 36) / 46, and moves follow it."""
    from ns_pz.agents.learning.alphazero import sample_move
    from ns_pz.agents.learning.puct import PUCTTree

    visits = np.array([1, 3, 0, 6])
    tree = PUCTTree(visits, np.zeros(4), 0.0, 1, 10, np.full(4, 0.25))
    expected = np.array([1.0, 9.0, 0.0, 36.0]) / 46.0
    rng = np.random.default_rng(5)
    twin = np.random.default_rng(5)
    policy, action = sample_move(tree, 0.5, rng)
    np.testing.assert_allclose(policy, expected)
    assert action == twin.choice(4, p=expected)
    counts = np.bincount([sample_move(tree, 0.5, rng)[1] for _ in range(4000)], minlength=4)
    np.testing.assert_allclose(counts / 4000, expected, atol=0.02)
    assert counts[2] == 0


def _moves(rewards, root_qs):
    from ns_pz.agents.learning.alphazero import Move

    return [
        Move(np.zeros(2, np.float32), np.ones(2), np.full(2, 0.5), q, 0, r)
        for r, q in zip(rewards, root_qs, strict=True)
    ]


def test_value_targets_are_the_return_from_each_move_on():
    """Rewards (1, 0, 2), γ = 0.5: z = (1 + 0.5·(0 + 0.5·2), 0 + 0.5·2, 2) = (1.5, 1, 2)."""
    from ns_pz.agents.learning.alphazero import value_targets

    moves = _moves([1.0, 0.0, 2.0], [7.0, 8.0, 9.0])
    np.testing.assert_allclose(value_targets(moves, "return", 0.5), [1.5, 1.0, 2.0])
    np.testing.assert_allclose(value_targets(moves, "root_q", 0.5), [7.0, 8.0, 9.0])
    with pytest.raises(ValueError, match="value_target='mc'"):
        value_targets(moves, "mc", 0.5)


def _self_play(max_steps, seed=1):
    """A self-play episode on FrozenLake θ_0 from the start, a random network, world seed 3."""
    from ns_pz.agents.learning.alphazero import self_play_episode

    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    env.reset(seed=0)
    model = env.planning_model()
    function = _random_function(env.family.observation_space, seed)
    settings = PUCTSettings(12, 5, 1.0, 0.9)
    world = np.random.default_rng(3)
    moves, tail = self_play_episode(
        model, 0, function, settings, 0.5, np.random.default_rng(2), world, max_steps
    )
    return env, function, moves, tail


def test_a_self_play_episode_records_the_searches_it_played():
    """Each move's policy is its visits at the episode's temperature; transitions are the world's.

    Replaying the moves with the world's generator (seed 3) through the family's step gives the
    same states and rewards; the episode ends in a terminal state, so nothing is bootstrapped.
    """
    from ns_pz.agents.learning.alphazero import value_targets

    env, _, moves, tail = _self_play(max_steps=100)
    world, state, terminal = np.random.default_rng(3), 0, False
    for move in moves:
        squared = move.visits**2 / (move.visits**2).sum()
        np.testing.assert_allclose(move.policy, squared)
        assert move.features.argmax() == state
        state, reward, terminal = env.family.step(state, move.action, env.base_params, world)
        assert move.reward == reward
    assert terminal and tail == 0.0 and len(moves) < 100
    z = value_targets(moves, "return", 0.9, tail)
    assert z[-1] == moves[-1].reward and z[0] == pytest.approx(
        sum(0.9**k * m.reward for k, m in enumerate(moves))
    )


def test_an_episode_cut_short_is_bootstrapped_with_the_networks_value():
    """Cut at 2 moves in a non-terminal state: the tail is the network's value of that state."""
    from ns_pz.agents.learning.alphazero import value_targets

    env, function, moves, tail = _self_play(max_steps=2)
    world, state = np.random.default_rng(3), 0
    for move in moves:
        state, _, terminal = env.family.step(state, move.action, env.base_params, world)
    assert len(moves) == 2 and not terminal
    assert tail == pytest.approx(function(state)[1])
    rewards = [m.reward for m in moves]
    z = value_targets(moves, "return", 0.9, tail)
    np.testing.assert_allclose(
        z, [rewards[0] + 0.9 * (rewards[1] + 0.9 * tail), rewards[1] + 0.9 * tail], rtol=1e-6
    )


def test_exploring_starts_draw_from_the_states_an_episode_can_be_in():
    """CliffWalking: every cell but the cliff (never occupied) and the goal (terminal)."""
    from ns_pz.agents.learning.alphazero import exploring_states

    env = ns_pz.make_gym("ns_pz/CliffWalking-v0", params={"slip": [1.0, 0.0, 0.0, 0.0]})
    env.reset(seed=0)
    np.testing.assert_array_equal(exploring_states(env.planning_model()), np.arange(37))
    lake = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    lake.reset(seed=0)
    holes_and_goal = {5, 7, 11, 12, 15}
    assert set(exploring_states(lake.planning_model())) == set(range(16)) - holes_and_goal


def test_exploring_starts_need_a_tabular_family():
    """CartPole has no outcome table: the message says so; a fraction outside [0, 1] is refused."""
    cartpole = ns_pz.make_gym("ns_pz/CartPole-v0").family
    with pytest.raises(ValueError, match="exploring_starts=0.5 needs a tabular family"):
        AlphaZeroArgs(exploring_starts=0.5).for_family(cartpole)
    AlphaZeroArgs().for_family(cartpole)  # 0: fine
    with pytest.raises(ValueError, match=r"exploring_starts=1.5 must lie in \[0.0, 1.0\]"):
        AlphaZeroArgs(exploring_starts=1.5)


@pytest.mark.usefixtures("_tmp_cache")
def test_the_quick_cliff_walking_network_is_worth_searching_with():
    """The shipped quick CliffWalking AlphaZero (seconds of self-play) plays θ_0 near the optimum.

    PUCT as the table runs it (50 simulations, the paper's root noise ε 0.75) from the start, 8
    seeded episodes: every one reaches the goal, mean >= 80 (the optimum is 88; a network trained
    on 40 episodes from the start scored a mean of 72, 59 at worst, and its prior alone looped).
    """
    from ns_pz.experiments.spec import load_spec

    spec = load_spec("cliffwalking-single", "quick")
    (hyper,) = [agent.hyper for agent in spec.agents if agent.name == "alphazero"]

    def make():
        return ns_pz.make_gym(
            "ns_pz/CliffWalking-v0",
            goal_reward=100.0,
            params={"slip": [1.0, 0.0, 0.0, 0.0]},
            max_episode_steps=200,
        )

    agent = agent_entry("alphazero").make(make(), hyper)
    returns = [e.episode_return for e in evaluate(make, agent, range(8))]
    assert min(returns) > 0 and np.mean(returns) >= 80, returns


def test_training_keeps_the_best_evaluated_network(_tmp_cache):
    """The kept network is the one of the best held-out evaluation, not the last."""
    from ns_pz.agents.learning.alphazero import train_alphazero
    from ns_pz.agents.learning.trained import training_env

    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    args = AlphaZeroArgs(
        episodes=6, iterations=8, evaluate_every=2, evaluation_episodes=2, max_episode_steps=30
    ).for_family(env.family)
    weights, info = train_alphazero(training_env(env, 30), args, 0)
    episodes = [episode for episode, _ in info["evaluations"]]
    assert episodes == [2, 4, 6]
    assert info["kept_evaluation"] == max(score for _, score in info["evaluations"])


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("iterations", 0, "iterations=0 must be an int >= 1"),
        ("depth", -1, "depth=-1 must be an int >= 0"),
        ("depth", 2.5, "depth=2.5 must be an int >= 0"),
    ],
)
def test_puct_settings_refuse_counts_the_kernels_cannot_size(field, value, match):
    """A negative depth would size the compiled search's path arrays below what it writes."""
    settings = {"iterations": 10, "depth": 5, "c": 1.0, "gamma": 0.9, field: value}
    with pytest.raises(ValueError, match=match):
        PUCTSettings(**settings)
