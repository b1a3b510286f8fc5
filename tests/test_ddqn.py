"""Double DQN: the target, the training on θ_0, the agent and its catalog entry."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import evaluate
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning import ddqn
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.ddqn import (
    DoubleDQN,
    double_dqn_target,
    dqn_target,
    new_learner,
    train_ddqn,
)
from ns_pz.agents.learning.replay import Batch, ReplayBuffer
from ns_pz.agents.learning.seeding import training_seeds
from ns_pz.agents.learning.trained import training_env

import ns_pz

FROZEN_LAKE = {"slip": [0.7, 0.15, 0.15]}


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))


@pytest.fixture(params=["compiled", "numpy"])
def step_path(request, monkeypatch):
    """Run the test with the compiled elementwise kernels and again with NumPy alone."""
    if request.param == "compiled":
        pytest.importorskip("numba")
    else:
        monkeypatch.setattr(ddqn, "compiled_step", lambda: None)
    return request.param


def test_double_target_differs_from_vanilla_exactly_where_the_argmaxes_differ():
    """Online net picks, target net evaluates; vanilla takes the target net's max."""
    online = np.array([[1.0, 5.0, 2.0], [4.0, 0.0, 1.0], [0.0, 3.0, 9.0], [2.0, 1.0, 0.0]])
    target = np.array([[7.0, 1.0, 3.0], [6.0, 2.0, 8.0], [1.0, 2.0, 5.0], [3.0, 4.0, 1.0]])
    rewards = np.array([1.0, 0.0, -1.0, 0.5])
    terminated = np.array([0.0, 0.0, 0.0, 1.0])
    gamma = 0.9
    double = double_dqn_target(online, target, rewards, terminated, gamma)
    vanilla = dqn_target(target, rewards, terminated, gamma)
    # row 0: online argmax 1 -> target 1.0; vanilla max 7.0
    # row 1: online argmax 0 -> target 6.0; vanilla max 8.0
    # row 2: online argmax 2 -> target 5.0 = the target's own max: equal
    # row 3: terminal, no bootstrap: equal
    np.testing.assert_allclose(double, [1.9, 5.4, 3.5, 0.5])
    np.testing.assert_allclose(vanilla, [7.3, 7.2, 3.5, 0.5])
    assert (double != vanilla).tolist() == [True, True, False, False]


def _table_weights(q_table):
    """Weights whose Q of one-hot state ``s`` is ``q_table[s]`` (the hidden layer passes it on)."""
    q_table = np.asarray(q_table, dtype=np.float64)
    n, a = q_table.shape
    return {
        "q.0.weight": np.eye(n),
        "q.0.bias": np.zeros(n),
        "q.1.weight": q_table.T.copy(),
        "q.1.bias": np.zeros(a),
    }


def _table_learner(online, target, args):
    learner = DoubleDQN.from_weights(_table_weights(online), "q", args)
    learner.target[:] = DoubleDQN.from_weights(_table_weights(target), "q", args).params
    return learner


def _tiny_batch():
    """Two transitions of a 3-state, 3-action table: 0 -a1, r1-> 2 and 1 -a0, r-1-> 2 (ends)."""
    buffer = ReplayBuffer(2, 3)
    eye = np.eye(3, dtype=np.float32)
    buffer.add(eye[0], 1, 1.0, eye[2], False)
    buffer.add(eye[1], 0, -1.0, eye[2], True)
    return buffer.sample(2, np.random.default_rng(0)), buffer


def test_the_loss_is_the_double_dqn_loss_on_a_hand_computed_batch(step_path):
    """Online picks the next action (1, value 6), the target net values it (2): y = 1 + 0.5 * 2.

    Q_online(0, 1) = 0, so the non-terminal transition's squared error is (0 - 2)^2 = 4; the
    terminal one has y = -1 and Q_online(1, 0) = 0, squared error 1: loss 2.5. A vanilla target
    (the target net's max, 8: y = 5) gives (25 + 1) / 2 = 13; swapped roles (the target net
    picks 2, the online net values it 4: y = 3) 5; the online net alone (6: y = 4) 8.5.
    """
    learner = _table_learner(
        [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 6.0, 4.0]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 2.0, 8.0]],
        DDQNArgs(gamma=0.5, hidden=(3,)),
    )
    _, buffer = _tiny_batch()
    batch = Batch(
        buffer.features, buffer.actions, buffer.rewards, buffer.next_features, buffer.terminated
    )
    assert learner.loss_and_gradient(batch) == pytest.approx(2.5)


def test_a_gradient_step_polyak_averages_a_separate_target(step_path):
    """After one step the target is τ·online_new + (1-τ)·target_old, not the online net."""
    learner = _table_learner(
        [[0.0, 3.0, 0.0], [0.0, 0.0, 0.0], [1.0, 6.0, 4.0]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 2.0, 8.0]],
        DDQNArgs(gamma=0.5, tau=0.25, hidden=(3,)),
    )
    old = learner.target.copy()
    batch, _ = _tiny_batch()
    learner.gradient_step(batch)
    assert not np.array_equal(learner.params, learner.target)
    np.testing.assert_allclose(learner.target, 0.25 * learner.params + 0.75 * old, rtol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_gradient_steps_match_torch_autograd_and_adam(seed, step_path):
    """Loss, gradient, Adam step (with weight decay) and Polyak update equal torch's in float64.

    Three steps of a two-hidden-layer net on a random batch, against ``nn.Linear`` layers
    holding the same weights, ``F.mse_loss`` to the Double-DQN target, ``backward`` and
    ``torch.optim.Adam``: the hand-written backward pass and optimiser are the textbook ones.
    """
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(seed)
    args = DDQNArgs(hidden=(8, 6), gamma=0.9, tau=0.1, weight_decay=1e-3, learning_rate=1e-2)
    learner = new_learner(5, 3, args, seed)
    learner.target += rng.normal(size=learner.size) * 0.1
    size = 7
    batch = Batch(
        rng.normal(size=(size, 5)).astype(np.float32),
        rng.integers(3, size=size),
        rng.normal(size=size).astype(np.float32),
        rng.normal(size=(size, 5)).astype(np.float32),
        (rng.random(size) < 0.3).astype(np.float32),
    )

    def torch_net(layers):
        modules = []
        for w, b in layers:
            linear = torch.nn.Linear(*w.shape, dtype=torch.float64)
            with torch.no_grad():
                linear.weight.copy_(torch.from_numpy(w.T.copy()))
                linear.bias.copy_(torch.from_numpy(b.copy()))
            modules += [linear, torch.nn.ReLU()]
        return torch.nn.Sequential(*modules[:-1])

    def flat(network):
        linears = [m for m in network if isinstance(m, torch.nn.Linear)]
        return np.concatenate(
            [
                np.concatenate([m.weight.detach().numpy().T.ravel(), m.bias.detach().numpy()])
                for m in linears
            ]
        )

    def flat_grad(network):
        linears = [m for m in network if isinstance(m, torch.nn.Linear)]
        return np.concatenate(
            [
                np.concatenate([m.weight.grad.numpy().T.ravel(), m.bias.grad.numpy()])
                for m in linears
            ]
        )

    online, target = torch_net(learner.layers), torch_net(learner.target_layers)
    optimizer = torch.optim.Adam(
        online.parameters(), lr=args.learning_rate, weight_decay=args.weight_decay
    )
    as_tensor = lambda a: torch.from_numpy(np.asarray(a, dtype=np.float64))  # noqa: E731
    for _ in range(3):
        with torch.no_grad():
            chosen = online(as_tensor(batch.next_features)).argmax(1, keepdim=True)
            bootstrap = target(as_tensor(batch.next_features)).gather(1, chosen).squeeze(1)
            y = (
                as_tensor(batch.rewards)
                + args.gamma * (1 - as_tensor(batch.terminated)) * bootstrap
            )
        taken = online(as_tensor(batch.features))
        taken = taken.gather(1, torch.from_numpy(batch.actions)[:, None]).squeeze(1)
        loss = torch.nn.functional.mse_loss(taken, y)
        optimizer.zero_grad()
        loss.backward()
        assert learner.loss_and_gradient(batch) == pytest.approx(loss.item(), rel=1e-12)
        np.testing.assert_allclose(learner.grad, flat_grad(online), rtol=1e-9, atol=1e-14)
        optimizer.step()
        with torch.no_grad():
            for t, o in zip(target.parameters(), online.parameters(), strict=True):
                t.mul_(1 - args.tau).add_(o, alpha=args.tau)
        learner.gradient_step(batch)
        np.testing.assert_allclose(learner.params, flat(online), rtol=1e-9, atol=1e-14)
        np.testing.assert_allclose(learner.target, flat(target), rtol=1e-9, atol=1e-14)


def test_a_new_learner_has_a_separate_target_equal_to_the_online_net():
    """The target network is a copy, not the online parameters (NS-Gym shares one module)."""
    learner = new_learner(4, 2, DDQNArgs(hidden=(8,)), 0)
    assert learner.target is not learner.params
    assert np.array_equal(learner.target, learner.params)
    assert [w.shape for w, _ in learner.layers] == [(4, 8), (8, 2)]
    bound = 1.0 / np.sqrt(4)
    assert np.abs(learner.layers[0][0]).max() <= bound  # torch's Linear default init
    assert not np.array_equal(learner.params, new_learner(4, 2, DDQNArgs(hidden=(8,)), 1).params)


def test_learners_refuse_weights_that_do_not_chain():
    """A layer whose input is not the previous layer's output is named."""
    weights = {
        "q.0.weight": np.zeros((8, 4)),
        "q.0.bias": np.zeros(8),
        "q.1.weight": np.zeros((2, 7)),
        "q.1.bias": np.zeros(2),
    }
    with pytest.raises(ValueError, match="layer q.1 has mismatched shapes"):
        DoubleDQN.from_weights(weights, "q", DDQNArgs())
    with pytest.raises(ValueError, match="no layer x.0"):
        DoubleDQN.from_weights(weights, "x", DDQNArgs())


def test_exported_weights_load_back_unchanged():
    """``export`` and ``from_weights`` are inverses (torch's ``Linear.weight`` layout)."""
    learner = new_learner(3, 2, DDQNArgs(hidden=(5, 4)), 7)
    weights = learner.export("q")
    assert [weights[f"q.{i}.weight"].shape for i in range(3)] == [(5, 3), (4, 5), (2, 4)]
    again = DoubleDQN.from_weights(weights, "q", DDQNArgs())
    assert np.array_equal(again.params, learner.params)


def test_training_seeds_are_independent_streams():
    """The generator, the env seed and the initialisation seed differ, and all follow the seed."""
    rng, env_seed, init_seed = training_seeds(3)
    again = training_seeds(3)
    assert (env_seed, init_seed) == again[1:] and rng.random() == again[0].random()
    assert len({env_seed, init_seed, 3}) == 3
    # the env is not seeded with the generator's own integer (same stream, shifted by a draw)
    first = training_seeds(3)[0].integers(2**31, size=4)
    assert not np.array_equal(first, np.random.default_rng(3).integers(2**31, size=4))


def test_training_resets_the_env_with_its_own_stream():
    """The env's first reset gets the spawned env seed, not the training seed itself."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    args = DDQNArgs(total_steps=10, learning_starts=100).for_family(env.family)
    training = training_env(env, args.max_episode_steps)
    seen = []
    original = training.reset

    def reset(*, seed=None, options=None):
        seen.append(seed)
        return original(seed=seed, options=options)

    training.reset = reset
    train_ddqn(training, args, 3)
    assert seen[0] == training_seeds(3)[1] != 3


def test_training_is_reproducible_from_its_seed():
    """Training is reproducible from its seed."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    args = DDQNArgs(total_steps=1500, learning_starts=100).for_family(env.family)
    first, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    second, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    other, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 4)
    assert all(np.array_equal(first[k], second[k]) for k in first)
    assert not all(np.array_equal(first[k], other[k]) for k in first)
    assert [first[f"q.{i}.weight"].shape for i in range(2)] == [(64, 16), (4, 64)]


def _mean_return(env_id, params, agent, seeds, **kwargs):
    episodes = evaluate(lambda: ns_pz.make_gym(env_id, params=params, **kwargs), agent, seeds)
    return float(np.mean([e.episode_return for e in episodes]))


def test_ddqn_learns_frozen_lake_at_theta0():
    """20k steps (seconds) give a greedy policy far above random on θ_0 (p = 0.7)."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    agent = agent_entry("ddqn").make(env, {"total_steps": 20_000})
    learned = _mean_return("ns_pz/FrozenLake-v0", FROZEN_LAKE, agent, range(100))
    random = _mean_return(
        "ns_pz/FrozenLake-v0", FROZEN_LAKE, RandomAgent(env.action_space), range(100)
    )
    assert random < 0.1 and learned > 0.5


def test_ddqn_learns_cartpole_at_theta0():
    """Ddqn learns cartpole at theta0."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0", max_episode_steps=300)
    agent = agent_entry("ddqn").make(env, {"total_steps": 20_000})
    learned = _mean_return("ns_pz/CartPole-v0", {}, agent, range(10), max_episode_steps=300)
    random = _mean_return(
        "ns_pz/CartPole-v0", {}, RandomAgent(env.action_space), range(10), max_episode_steps=300
    )
    assert random < 40 and learned > 3 * random


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("total_steps", 0, "total_steps=0 must be >= 1"),
        ("gamma", 1.5, r"gamma=1.5 must lie in \[0.0, 1.0\]"),
        ("hidden", [64, 0], "hidden=0 must be >= 1"),
        ("hidden", "64", "must be a non-empty list"),
        ("seed", 1.0, "seed=1.0 must be an integer"),
    ],
)
def test_bad_args_are_refused(field, value, match):
    """Bad args are refused."""
    with pytest.raises((TypeError, ValueError), match=match):
        DDQNArgs(**{field: value})


def test_a_gradient_step_flushes_subnormal_weights_moments_and_target(step_path):
    """The weights of a state no batch holds decay into float64's subnormal range; flushed to 0.

    State 2 is only ever a next state here, so its first-layer weights get weight decay alone:
    set subnormal, no subnormal is left after a step in the weights, their moments or the
    target network, and every other weight moves as in a learner that had them at 0.
    """
    learner = new_learner(3, 3, DDQNArgs(hidden=(4,), weight_decay=1e-2), 0)
    row = slice(2 * 4, 3 * 4)  # layer 0's weights from input 2
    learner.params[row] = 1e-310
    learner.target[row] = 1e-310
    plain = new_learner(3, 3, DDQNArgs(hidden=(4,), weight_decay=1e-2), 0)
    plain.params[row], plain.target[row] = 0.0, 0.0
    batch, _ = _tiny_batch()
    assert learner.gradient_step(batch) == plain.gradient_step(batch)
    tiny = np.finfo(np.float64).tiny
    for state in (learner.params, learner.m, learner.v, learner.target):
        assert not np.any((state != 0) & (np.abs(state) < tiny))
    others = np.ones(learner.size, dtype=bool)
    others[row] = False
    np.testing.assert_array_equal(learner.params[others], plain.params[others])
    np.testing.assert_array_equal(learner.target[others], plain.target[others])


def _random_batch(rng, size, inputs, num_actions, one_hot):
    if one_hot:
        eye = np.eye(inputs, dtype=np.float32)
        x, next_x = eye[rng.integers(inputs, size=size)], eye[rng.integers(inputs, size=size)]
    else:
        x = rng.normal(size=(size, inputs)).astype(np.float32)
        next_x = rng.normal(size=(size, inputs)).astype(np.float32)
    return Batch(
        x,
        rng.integers(num_actions, size=size),
        rng.normal(size=size).astype(np.float32),
        next_x,
        (rng.random(size) < 0.2).astype(np.float32),
    )


def _tied_learner(inputs, args):
    """A learner of three actions whose actions 0 and 1 tie until a step tells them apart."""
    learner = new_learner(inputs, 3, args, 5)
    w, b = learner.layers[-1]
    w[:, 1], b[1] = w[:, 0], b[0]
    learner.sync_target()
    return learner


@pytest.mark.parametrize(
    ("inputs", "hidden", "one_hot", "weight_decay"),
    [(6, (5,), True, 1e-2), (4, (7, 6), False, 0.0), (3, (4, 4, 4), False, 1e-4)],
)
def test_compiled_and_numpy_gradient_steps_agree_bit_for_bit(inputs, hidden, one_hot, weight_decay):
    """Where numba is installed the elementwise parts run compiled: the same bits, step by step.

    Sixty steps on random batches (ties among the next Q-values included: the output layer
    starts with equal columns), compared exactly: losses, gradients, weights, Adam's moments and
    the target network.
    """
    pytest.importorskip("numba")
    args = DDQNArgs(hidden=hidden, gamma=0.9, tau=0.05, weight_decay=weight_decay)
    rng = np.random.default_rng(len(hidden))
    batches = [_random_batch(rng, 9, inputs, 3, one_hot) for _ in range(60)]
    runs = []
    for path in ("compiled", "numpy"):
        with pytest.MonkeyPatch.context() as patch:
            if path == "numpy":
                patch.setattr(ddqn, "compiled_step", lambda: None)
            learner = _tied_learner(inputs, args)
            losses, grads = [], []
            for batch in batches:
                losses.append(learner.gradient_step(batch))
                grads.append(learner.grad.copy())
            runs.append((losses, grads, learner))
    (losses, grads, compiled), (np_losses, np_grads, plain) = runs
    assert losses == np_losses
    np.testing.assert_array_equal(np.array(grads), np.array(np_grads))
    for name in ("params", "m", "v", "target"):
        np.testing.assert_array_equal(getattr(compiled, name), getattr(plain, name), err_msg=name)
    assert compiled.steps == plain.steps == 60


def _blas_or_skip():
    """NumPy's BLAS routines for compiled steps, or skip (no numba, or NumPy without OpenBLAS)."""
    pytest.importorskip("numba")
    from ns_pz.agents.learning.numpy_blas import blas_routines

    if blas_routines() is None:
        pytest.skip("NumPy's BLAS is not the OpenBLAS its wheels bundle")


def _filled_buffer(rng, inputs, num_actions, one_hot, size=200):
    buffer = ReplayBuffer(size, inputs)
    batch = _random_batch(rng, size, inputs, num_actions, one_hot)
    for i in range(size):
        buffer.add(
            batch.features[i],
            int(batch.actions[i]),
            float(batch.rewards[i]),
            batch.next_features[i],
            bool(batch.terminated[i]),
        )
    return buffer


@pytest.mark.parametrize(
    ("inputs", "hidden", "one_hot", "batch_size"),
    [(16, (64,), True, 64), (5, (7, 6), False, 9), (4, (3, 4, 5), False, 2), (8, (6, 5), False, 1)],
)
def test_whole_compiled_steps_are_numpys_bit_for_bit(inputs, hidden, one_hot, batch_size):
    """Replay steps and greedy actions through NumPy's BLAS from compiled code: NumPy's bits.

    Three paths from the same weights, buffer and generator: whole steps compiled (the
    products through NumPy's own BLAS routines), only the elementwise parts compiled, NumPy
    alone. Losses, weights, Adam's moments, the target and every greedy action are equal.
    """
    _blas_or_skip()
    args = DDQNArgs(hidden=hidden, gamma=0.9, tau=0.05, weight_decay=1e-3, batch_size=batch_size)
    buffer = _filled_buffer(np.random.default_rng(1), inputs, 3, one_hot)
    probes = _random_batch(np.random.default_rng(2), 16, inputs, 3, one_hot).features
    for rows in (batch_size, 16, 1):  # the check on random data passed: compiled, not NumPy
        assert ddqn.products_for([inputs, *hidden, 3], rows) is not None
    runs = {}
    for path in ("whole", "elementwise", "numpy"):
        with pytest.MonkeyPatch.context() as patch:
            if path == "elementwise":
                patch.setattr(ddqn, "products_for", lambda widths, rows: None)
            if path == "numpy":
                patch.setattr(ddqn, "compiled_step", lambda: None)
            learner = _tied_learner(inputs, args)
            rng = np.random.default_rng(3)
            losses, actions = [], []
            for _ in range(40):
                losses.append(learner.replay_step(buffer, rng))
                actions.append([learner.greedy(x) for x in probes])
                actions.append(learner.greedy_rows(probes).tolist())
                actions.append(learner.greedy_rows(np.asfortranarray(probes)).tolist())
                actions.append(learner.greedy_rows(probes[:1]).tolist())
                actions.append(learner.greedy_rows(probes[:0]).tolist())
                actions.append([learner.greedy(probes[0].tolist())])
            runs[path] = (losses, actions, learner)
    for path in ("elementwise", "numpy"):
        assert runs[path][0] == runs["whole"][0], path
        assert runs[path][1] == runs["whole"][1], path
        for name in ("params", "grad", "m", "v", "target"):
            np.testing.assert_array_equal(
                getattr(runs[path][2], name), getattr(runs["whole"][2], name), err_msg=name
            )


def test_a_network_with_a_width_of_one_keeps_numpys_products():
    """NumPy multiplies by a vector through other routines: such networks are not compiled."""
    pytest.importorskip("numba")
    assert ddqn.products_for([4, 1, 3], 64) is None
    assert ddqn.products_for([4, 8, 1], 1) is None
    learner = new_learner(4, 1, DDQNArgs(hidden=(8,), batch_size=4), 0)
    buffer = _filled_buffer(np.random.default_rng(0), 4, 1, False, size=10)
    assert np.isfinite(learner.replay_step(buffer, np.random.default_rng(0)))
    assert learner.greedy(np.zeros(4, dtype=np.float32)) == 0


def test_without_numpys_openblas_the_learner_keeps_numpys_products():
    """A NumPy built against another BLAS: no compiled products, and the same learning."""
    _blas_or_skip()
    args = DDQNArgs(hidden=(5,), batch_size=9)
    buffer = _filled_buffer(np.random.default_rng(0), 6, 3, False)
    probes = _random_batch(np.random.default_rng(1), 4, 6, 3, False).features
    runs = []
    for missing in (False, True):
        with pytest.MonkeyPatch.context() as patch:
            if missing:
                patch.setattr(ddqn, "blas_routines", lambda: None)
            ddqn._checked_products.cache_clear()
            try:
                assert (ddqn.products_for([6, 5, 3], 9) is None) == missing
                learner = new_learner(6, 3, args, 0)
                rng = np.random.default_rng(2)
                losses = [learner.replay_step(buffer, rng) for _ in range(20)]
                actions = learner.greedy_rows(probes).tolist()
                runs.append((losses, actions, learner.params.copy()))
            finally:
                ddqn._checked_products.cache_clear()
    assert runs[0][:2] == runs[1][:2]
    np.testing.assert_array_equal(runs[0][2], runs[1][2])


def test_the_blas_routines_are_found_where_numpy_bundles_openblas():
    """Both routines are found where NumPy bundles a 64-bit-integer OpenBLAS.

    NumPy's PyPI wheels do: scipy-openblas64 since NumPy 2, openblas64 for NumPy 1.26.
    """
    from ns_pz.agents.learning.numpy_blas import blas_routines
    from threadpoolctl import threadpool_info

    bundled = any("openblas64_" in (library.get("filepath") or "") for library in threadpool_info())
    if not bundled:
        pytest.skip("this NumPy does not bundle a 64-bit-integer OpenBLAS")
    routines = blas_routines()
    assert routines is not None and routines.shape == (2,) and (routines != 0).all()


def test_the_compiled_target_picks_the_first_best_and_a_nan_as_argmax_does():
    """``td_delta``'s choice of the next action is ``argmax``'s, NaN and ties included."""
    kernels = ddqn.compiled_step()
    if kernels is None:
        pytest.skip("numba is not installed")
    online = np.array([[1.0, 3.0, 3.0], [2.0, np.nan, 5.0], [np.nan, 9.0, 1.0], [-1.0, -1.0, -2.0]])
    target = np.arange(12.0).reshape(4, 3)
    rewards, terminated = np.array([0.5, 0.0, 1.0, 2.0]), np.array([0.0, 0.0, 0.0, 1.0])
    q = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0], [4.0, 0.0, 0.0]])
    actions = np.array([0, 1, 2, 0])
    delta, squares = np.empty_like(q), np.empty(4)
    kernels.td_delta(q, online, target, actions, rewards, terminated, 0.9, delta, squares)
    y = double_dqn_target(online, target, rewards, terminated, 0.9)
    error = q[np.arange(4), actions] - y
    np.testing.assert_array_equal(squares, error * error)
    expected = np.zeros_like(q)
    expected[np.arange(4), actions] = 2.0 * error / 4
    np.testing.assert_array_equal(delta, expected)


def test_the_compiled_target_refuses_an_action_out_of_range_as_numpy_does():
    """An action index past the network's outputs raises IndexError on both paths."""
    pytest.importorskip("numba")
    drawn = _random_batch(np.random.default_rng(0), 4, 3, 3, True)
    actions = np.array([0, 1, 3, 2])  # 3 is past the last of three actions
    batch = Batch(drawn.features, actions, drawn.rewards, drawn.next_features, drawn.terminated)
    for path in ("compiled", "numpy"):
        with pytest.MonkeyPatch.context() as patch:
            if path == "numpy":
                patch.setattr(ddqn, "compiled_step", lambda: None)
            with pytest.raises(IndexError):
                new_learner(3, 3, DDQNArgs(hidden=(4,)), 0).gradient_step(batch)


def test_training_is_the_same_with_and_without_numba():
    """A short training run gives the same network bit for bit on both paths."""
    pytest.importorskip("numba")
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params=FROZEN_LAKE)
    args = DDQNArgs(total_steps=1500, learning_starts=100).for_family(env.family)
    compiled, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ddqn, "compiled_step", lambda: None)
        plain, _ = train_ddqn(training_env(env, args.max_episode_steps), args, 3)
    assert all(np.array_equal(compiled[k], plain[k]) for k in compiled)


def test_whole_compiled_steps_refuse_what_numpys_products_refuse():
    """Inputs of the wrong size and actions past the outputs: errors, not memory read blind."""
    _blas_or_skip()
    learner = new_learner(5, 3, DDQNArgs(hidden=(7,), batch_size=8), 0)
    for x in (np.zeros(4, dtype=np.float32), np.zeros(6, dtype=np.float32)):
        with pytest.raises(ValueError, match="inputs=5"):
            learner.greedy(x)
        with pytest.raises(ValueError, match="inputs=5"):
            learner.greedy_rows(np.stack([x, x]))
    with pytest.raises(ValueError, match="inputs=5"):
        learner.replay_step(
            _filled_buffer(np.random.default_rng(0), 6, 3, False), np.random.default_rng(0)
        )
    buffer = _filled_buffer(np.random.default_rng(0), 5, 3, False, size=10)
    buffer.actions[:] = 3  # past the last of three actions
    before = learner.params.copy()
    with pytest.raises(IndexError):
        learner.replay_step(buffer, np.random.default_rng(0))
    assert learner.steps == 0
    np.testing.assert_array_equal(learner.params, before)
