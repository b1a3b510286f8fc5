"""Double DQN: the target, the training on θ_0, the agent and its catalog entry."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents import evaluate
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.learning.config import DDQNArgs

import ns_pz

torch = pytest.importorskip("torch")
from ns_pz.agents.learning.ddqn import (  # noqa: E402
    double_dqn_target,
    dqn_target,
    gradient_step,
    new_learner,
    td_loss,
    train_ddqn,
)
from ns_pz.agents.learning.ddqn_wn import network_from  # noqa: E402
from ns_pz.agents.learning.networks import LayerCalls, mlp  # noqa: E402
from ns_pz.agents.learning.replay import Batch, ReplayBuffer  # noqa: E402
from ns_pz.agents.learning.seeding import training_seeds  # noqa: E402
from ns_pz.agents.learning.trained import training_env  # noqa: E402

FROZEN_LAKE = {"slip": [0.7, 0.15, 0.15]}


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))


def test_double_target_differs_from_vanilla_exactly_where_the_argmaxes_differ():
    """Online net picks, target net evaluates; vanilla takes the target net's max."""
    online = torch.tensor([[1.0, 5.0, 2.0], [4.0, 0.0, 1.0], [0.0, 3.0, 9.0], [2.0, 1.0, 0.0]])
    target = torch.tensor([[7.0, 1.0, 3.0], [6.0, 2.0, 8.0], [1.0, 2.0, 5.0], [3.0, 4.0, 1.0]])
    rewards = torch.tensor([1.0, 0.0, -1.0, 0.5])
    terminated = torch.tensor([0.0, 0.0, 0.0, 1.0])
    gamma = 0.9
    double = double_dqn_target(online, target, rewards, terminated, gamma)
    vanilla = dqn_target(target, rewards, terminated, gamma)
    # row 0: online argmax 1 -> target 1.0; vanilla max 7.0
    # row 1: online argmax 0 -> target 6.0; vanilla max 8.0
    # row 2: online argmax 2 -> target 5.0 = the target's own max: equal
    # row 3: terminal, no bootstrap: equal
    torch.testing.assert_close(double, torch.tensor([1.9, 5.4, 3.5, 0.5]))
    torch.testing.assert_close(vanilla, torch.tensor([7.3, 7.2, 3.5, 0.5]))
    assert (double != vanilla).tolist() == [True, True, False, False]


def _table_network(q_table):
    """A net whose Q of one-hot state ``s`` is ``q_table[s]`` (the hidden layer passes it on)."""
    q_table = np.asarray(q_table, dtype=np.float32)
    n, a = q_table.shape
    weights = {
        "q.0.weight": np.eye(n, dtype=np.float32),
        "q.0.bias": np.zeros(n, dtype=np.float32),
        "q.1.weight": q_table.T.copy(),
        "q.1.bias": np.zeros(a, dtype=np.float32),
    }
    return network_from(weights, "q")


def _tiny_batch():
    """Two transitions of a 3-state, 3-action table: 0 -a1, r1-> 2 and 1 -a0, r-1-> 2 (ends)."""
    buffer = ReplayBuffer(2, 3)
    eye = np.eye(3, dtype=np.float32)
    buffer.add(eye[0], 1, 1.0, eye[2], False)
    buffer.add(eye[1], 0, -1.0, eye[2], True)
    return buffer.sample(2, np.random.default_rng(0)), buffer


def test_td_loss_is_the_double_dqn_loss_on_a_hand_computed_batch():
    """Online picks the next action (1, value 6), the target net values it (2): y = 1 + 0.5 * 2.

    Q_online(0, 1) = 0, so the non-terminal transition's squared error is (0 - 2)^2 = 4; the
    terminal one has y = -1 and Q_online(1, 0) = 0, squared error 1: loss 2.5. A vanilla target
    (the target net's max, 8: y = 5) gives (25 + 1) / 2 = 13; swapped roles (the target net
    picks 2, the online net values it 4: y = 3) 5; the online net alone (6: y = 4) 8.5.
    """
    online = _table_network([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 6.0, 4.0]])
    target = _table_network([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 2.0, 8.0]])
    _, buffer = _tiny_batch()
    batch = Batch(
        buffer.features, buffer.actions, buffer.rewards, buffer.next_features, buffer.terminated
    )
    assert td_loss(online, target, batch, 0.5).item() == pytest.approx(2.5)


def test_a_gradient_step_polyak_averages_a_separate_target():
    """After one step the target is τ·online_new + (1-τ)·target_old, not the online net."""
    online = _table_network([[0.0, 3.0, 0.0], [0.0, 0.0, 0.0], [1.0, 6.0, 4.0]])
    target = _table_network([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 2.0, 8.0]])
    old = [p.detach().clone() for p in target.parameters()]
    optimizer = torch.optim.SGD(online.parameters(), lr=0.1)
    batch, _ = _tiny_batch()
    args = DDQNArgs(gamma=0.5, tau=0.25, hidden=(3,))
    gradient_step(online, target, optimizer, batch, args)
    for t, o, t_old in zip(target.parameters(), online.parameters(), old, strict=True):
        torch.testing.assert_close(t, 0.25 * o + 0.75 * t_old)


def test_a_new_learner_has_a_separate_target_equal_to_the_online_net():
    """The target network is a copy, not the online module (NS-Gym shares one module)."""
    online, target, optimizer = new_learner(4, 2, DDQNArgs(hidden=(8,)))
    assert target is not online
    for t, o in zip(target.parameters(), online.parameters(), strict=True):
        assert t is not o and torch.equal(t, o)
    assert [p for group in optimizer.param_groups for p in group["params"]] == list(
        online.parameters()
    )


def test_training_seeds_are_independent_streams():
    """The generator, the env seed and the torch seed differ, and all follow the seed."""
    rng, env_seed, torch_seed = training_seeds(3)
    again = training_seeds(3)
    assert (env_seed, torch_seed) == again[1:] and rng.random() == again[0].random()
    assert len({env_seed, torch_seed, 3}) == 3
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


def test_layer_calls_compute_the_modules_bits_and_gradients():
    """LayerCalls is the same forward pass as the module: equal outputs and equal gradients."""
    torch.manual_seed(3)
    network = mlp(4, (16, 8), 3)
    calls, detached = LayerCalls(network), LayerCalls(network, detached=True)
    x = torch.randn(32, 4)
    assert torch.equal(calls(x), network(x)) and torch.equal(detached(x), network(x))
    assert not detached(x).requires_grad
    network(x).square().sum().backward()
    expected = [p.grad.clone() for p in network.parameters()]
    network.zero_grad()
    calls(x).square().sum().backward()
    assert all(torch.equal(p.grad, g) for p, g in zip(calls.parameters(), expected, strict=True))
    with torch.no_grad():  # shared, not copied: an in-place update shows at once
        network[0].weight.add_(1.0)
    assert torch.equal(detached(x), network(x))
    with pytest.raises(TypeError, match="must be Linear layers with a ReLU between each two"):
        LayerCalls(
            torch.nn.Sequential(torch.nn.Linear(4, 4), torch.nn.Tanh(), torch.nn.Linear(4, 2))
        )
