"""AlphaZero self-play training on the stationary base environment θ_0, in NumPy.

The paper's AlphaZero, with NS-Gym's defects fixed: the policy loss is the cross-entropy
between the visit distribution and the network's *logits* (NS-Gym applied ``cross_entropy`` to
softmax outputs, a double softmax), and the network trains on a window of recent self-play
samples rather than only the last episode. The loop reads top to bottom:

for each episode: start it at the environment's start or, with probability
``exploring_starts`` (tabular families), at a state drawn uniformly from those an episode can be
in (:func:`episode_start`); play it with PUCT on the planning model (θ_0) under the current
network (:func:`self_play_episode`), recording per move the visit distribution at temperature
T and sampling the move from it (:func:`sample_move`); the value target of a move
(:func:`value_targets`) is the discounted return from that move to the episode's end
(AlphaZero's z), plus, where the episode was cut off by ``max_episode_steps`` rather than
ended, the network's value of the state it was cut off in (a time limit of self-play is not the
end of the task; ``value_target="root_q"``: the paper's and NS-Gym's visit-weighted root Q,
which learns nothing from sparse rewards until the search itself finds them); then ``epochs``
full-batch Adam steps on the window with ``loss = MSE(v, V_target) + CE(π_target,
softmax(logits))`` (weight decay in Adam); ``T <- max(decay * T, T_min)``.

Exploring starts make short, cheap episodes informative where a sparse reward lies far from
the start: on CliffWalking under the paper's root noise (ε 0.75), 40 episodes of up to 200
moves from the start left a network whose prior looped and whose value of the start was -35
(the optimum: 88); 150 episodes of at most 30 moves from uniformly drawn states, at about the
same cost, give one whose values rise towards the goal and whose search plays θ_0 near the
optimum.

The network kept is the best *evaluated* one: every ``evaluate_every`` episodes (and after the
last) the network plays ``evaluation_episodes`` episodes on held-out seeds as the agent will
act (PUCT with the same settings, the most visited action), and the one with the best mean
return is kept (the paper keeps the best 100-episode moving average of the noisy self-play
returns, which rewards the exploration of the moment rather than the network).

**NumPy, not torch.** The network (:class:`PolicyValueLearner`) is one ReLU MLP whose last
layer holds the policy logits and the value side by side (two heads on the same trunk output,
as one matrix), trained in float32 by :class:`~ns_pz.agents.learning.mlp.MLPLearner`. On the
full FrozenLake network (batches of up to 2,000 samples, 2,000 gradient steps) torch spent
5.5 CPU-s importing itself and, for its first optimiser, its compiler, and its gradient steps
slowed as weight decay drove unused weights subnormal; NumPy's steps averaged 1.5 ms on one
core, and the whole training went from 18.0 to 6.6 CPU-s (2-core machine, shared). The
exported weights keep the layout :class:`~ns_pz.agents.learning.puct.PolicyValueFunction`
reads (``trunk.i``, ``policy.0``, ``value.0``).
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.features import feature_size, features
from ns_pz.agents.learning.mlp import MLPLearner, export_layers
from ns_pz.agents.learning.puct import (
    PolicyValueFunction,
    PUCTSettings,
    PUCTTree,
    model_evaluation,
    puct,
    puct_tree,
)
from ns_pz.agents.learning.seeding import training_seeds

from ns_pz.views import NSGymEnv


def log_softmax(logits: np.ndarray) -> np.ndarray:
    """``log softmax`` of each row of ``logits``, computed stably."""
    shifted = logits - logits.max(axis=1, keepdims=True)
    return shifted - np.log(np.exp(shifted).sum(axis=1, keepdims=True))


class PolicyValueLearner:
    """AlphaZero's network and its optimiser: a ReLU trunk, policy logits and a scalar value.

    One MLP ``inputs -> hidden... -> num_actions + 1``: the trunk's layers with ReLU after each,
    then one linear layer whose first ``num_actions`` outputs are the policy logits and whose
    last is the value (the two heads of the trunk's output, as one matrix). Initial weights
    follow torch's ``nn.Linear`` default.

    Args:
        inputs: Feature size.
        hidden: Widths of the trunk's layers (the paper's "3 layers, 64 units": ``(64,) * 3``).
        num_actions: Policy outputs.
        args: Learning rate and weight decay.
        rng: Draws the initial weights.
        dtype: Arithmetic of the training (float32, as torch's default; float64 in tests).

    Raises:
        ValueError: No hidden layer.
    """

    def __init__(
        self,
        inputs: int,
        hidden: tuple[int, ...],
        num_actions: int,
        args: AlphaZeroArgs,
        rng: np.random.Generator,
        dtype: type = np.float32,
    ) -> None:
        if not hidden:
            raise ValueError(f"hidden={tuple(hidden)!r} must list at least one layer width")
        widths = [inputs, *hidden, num_actions + 1]
        self.num_actions = num_actions
        self.mlp = MLPLearner(
            widths,
            MLPLearner.initial_params(widths, rng),
            args.learning_rate,
            args.weight_decay,
            dtype,
        )

    def loss_and_gradient(
        self, x: np.ndarray, policy_targets: np.ndarray, value_targets: np.ndarray
    ) -> float:
        """``MSE(v, value_targets) + CE(policy_targets, softmax(logits))``; its gradient too.

        The loss is a batch mean of both terms; the cross-entropy is on the *logits* (NS-Gym
        applied it to softmax outputs). The gradient goes to the learner's ``grad``.

        Args:
            x: ``[batch, inputs]`` features.
            policy_targets: ``[batch, num_actions]`` visit distributions (rows sum to 1).
            value_targets: ``[batch]``.
        """
        hidden = self.mlp.forward(x)
        out = hidden[-1]
        logits, values = out[:, : self.num_actions], out[:, self.num_actions]
        targets = policy_targets.astype(self.mlp.dtype, copy=False)
        log_priors = log_softmax(logits)
        error = values - value_targets.astype(self.mlp.dtype, copy=False)
        batch = len(out)
        loss = float(np.mean(error * error)) - float((targets * log_priors).sum(axis=1).mean())
        delta = np.empty_like(out)
        delta[:, : self.num_actions] = (
            np.exp(log_priors) * targets.sum(axis=1, keepdims=True) - targets
        ) / batch
        delta[:, self.num_actions] = 2.0 * error / batch
        self.mlp.backward(hidden, delta)
        return loss

    def gradient_step(
        self, x: np.ndarray, policy_targets: np.ndarray, value_targets: np.ndarray
    ) -> float:
        """One Adam step on the loss of the batch; returns the loss before it."""
        loss = self.loss_and_gradient(x, policy_targets, value_targets)
        self.mlp.adam_step()
        return loss

    def export(self) -> dict[str, np.ndarray]:
        """The weights in :class:`PolicyValueFunction`'s layout (torch's ``Linear`` shapes)."""
        *trunk, (w, b) = self.mlp.layers
        a = self.num_actions
        return {
            **export_layers(trunk, "trunk"),
            **export_layers([(w[:, :a], b[:a])], "policy"),
            **export_layers([(w[:, a:], b[a:])], "value"),
        }


@dataclass(frozen=True)
class Move:
    """One self-play move.

    Attributes:
        features: The network input of the state moved from.
        visits: ``[num_actions]`` root visit counts of its search.
        policy: ``[num_actions]`` the policy target: the visits at the episode's temperature.
        root_q: The visit-weighted root Q of the search.
        action: The move played, drawn from ``policy``.
        reward: The reward of the transition it made.
    """

    features: np.ndarray
    visits: np.ndarray
    policy: np.ndarray
    root_q: float
    action: int
    reward: float


def sample_move(
    tree: PUCTTree, temperature: float, rng: np.random.Generator
) -> tuple[np.ndarray, int]:
    """The policy target ``N^(1/T)`` normalised and a move drawn from it with ``rng``."""
    policy = tree.policy_target(temperature)
    return policy, int(rng.choice(len(policy), p=policy))


def self_play_episode(
    model: Any,
    state: Any,
    function: PolicyValueFunction,
    settings: PUCTSettings,
    temperature: float,
    rng: np.random.Generator,
    world: np.random.Generator,
    max_steps: int,
) -> tuple[list[Move], float]:
    """Play from ``state`` in ``model``'s θ to a terminal state or ``max_steps`` moves.

    Each move searches ``model`` from the current state with ``rng`` and draws the move from
    the visit distribution at ``temperature`` (also with ``rng``); the move's real transition
    draws from ``world`` (``model.family.step`` under ``model.theta``: the stationary
    environment of training, stepped without the search ever touching its generator).

    Returns:
        The moves, and the network's value of the state the episode was cut off in (0 if it
        ended in a terminal state): what the return would have continued with.
    """
    family = model.family
    space = family.observation_space
    evaluate = model_evaluation(function, model)
    moves: list[Move] = []
    for _ in range(max_steps):
        tree = puct_tree(model, state, rng, evaluate, settings)
        policy, action = sample_move(tree, temperature, rng)
        x = features(space, family.observe(state))
        state, reward, terminal = family.step(state, action, model.theta, world)
        moves.append(Move(x, tree.visits, policy, tree.value_target(), action, float(reward)))
        if terminal:
            return moves, 0.0
    return moves, evaluate(state)[1]


def exploring_states(model: Any) -> np.ndarray:
    """The states an episode of a tabular ``model`` can be in, for exploring starts.

    Every state some non-terminal transition leads to (sorted): terminal states are left out,
    and so are cells the agent never occupies (CliffWalking's cliff, whose entry sends it back
    to the start).

    Raises:
        ValueError: ``model`` has no outcome table (exploring starts need a tabular family).
    """
    outcomes = getattr(model, "outcomes", None)
    if outcomes is None:
        raise ValueError(
            f"exploring starts need a tabular family (an outcome table); "
            f"{type(model.family).__name__} has none"
        )
    return np.unique(outcomes.next_states[~outcomes.terminals])


def value_targets(
    moves: list[Move], value_target: str, gamma: float, tail: float = 0.0
) -> np.ndarray:
    """``[len(moves)]`` value targets of one episode's moves.

    ``"return"``: the discounted return from each move on, ``z_t = r_t + γ z_{t+1}`` with
    ``r_t`` the reward of move ``t``'s own transition and ``tail`` after the last move (the
    value of the state an episode was cut off in, so a time limit of self-play does not read as
    the end of the task; 0 after a terminal state); ``"root_q"``: each move's visit-weighted
    root Q.

    Raises:
        ValueError: An unknown ``value_target``.
    """
    if value_target == "root_q":
        return np.array([move.root_q for move in moves], dtype=np.float32)
    if value_target != "return":
        raise ValueError(f"value_target={value_target!r} is not 'return' or 'root_q'")
    targets = np.zeros(len(moves), dtype=np.float32)
    for i in range(len(moves) - 1, -1, -1):
        tail = moves[i].reward + gamma * tail
        targets[i] = tail
    return targets


def evaluation_return(
    env: NSGymEnv,
    function: PolicyValueFunction,
    settings: PUCTSettings,
    seeds: list[int],
    rng: np.random.Generator,
) -> float:
    """Mean return of PUCT acting with ``function`` (most visited action) on episodes ``seeds``."""
    total = 0.0
    for seed in seeds:
        env.reset(seed=seed)
        done = False
        while not done:
            model = env.planning_model()
            evaluate = model_evaluation(function, model)
            action = puct(model, model.get_state(), rng, evaluate, settings).action
            _, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
    return total / len(seeds)


def episode_start(
    env: NSGymEnv, world: np.random.Generator, starts: np.ndarray | None, exploring: float
) -> Any:
    """The first state of a self-play episode, drawn with ``world``.

    With probability ``exploring`` (no draw when it is 0) a state of ``starts`` uniformly (an
    exploring start), else the family's initial state.
    """
    if starts is not None and exploring > 0.0 and world.random() < exploring:
        return starts[int(world.integers(len(starts)))].item()
    return env.family.initial_state(world)


def train_alphazero(
    env: NSGymEnv,
    args: AlphaZeroArgs,
    seed: int,
    progress: Callable[[int, int], bool] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Self-play ``args.episodes`` episodes in ``env`` (stationary, θ_0) and train the network.

    ``args`` must have its family defaults filled in (:meth:`AlphaZeroArgs.for_family`).
    Everything random comes from ``seed``, split into independent streams (episodes, searches
    and move sampling, initialisation, and the held-out evaluation episodes).
    ``progress`` is called after every episode with ``(episodes done, args.episodes)``; if it
    returns True, training stops there (the best network evaluated so far is returned).

    Returns:
        The kept network's weights (:class:`PolicyValueFunction` layout) and training figures.
    """
    if args.hidden is None:
        raise ValueError(f"args={args!r} must have hidden filled in (for_family)")
    settings = args.puct_settings()
    space = env.family.observation_space
    num_actions = int(env.action_space.n)  # type: ignore[attr-defined]  # Discrete
    rng, env_seed, init_seed = training_seeds(seed)
    # held-out evaluation episodes and their searches: streams of their own, the same for
    # every evaluation (common random numbers across the networks compared)
    held_out = np.random.SeedSequence([seed, 1]).generate_state(args.evaluation_episodes)
    evaluation_seeds = [int(s) for s in held_out]
    evaluation_search = np.random.SeedSequence([seed, 2])
    evaluation_env = NSGymEnv(
        env.family, params=env.base_params, max_episode_steps=env.max_episode_steps
    )
    # the searches' simulated transitions: a stream of their own (the model's own state is
    # never used: every search is handed its root)
    model = env.family.planning_model(
        env.base_params,
        env.family.initial_state(np.random.default_rng(0)),
        np.random.default_rng(np.random.SeedSequence([seed, 3])),
    )
    world = np.random.default_rng(env_seed)  # starts and real transitions of self-play
    starts = exploring_states(model) if args.exploring_starts > 0.0 else None
    start = time.perf_counter()
    network = PolicyValueLearner(
        feature_size(space), args.hidden, num_actions, args, np.random.default_rng(init_seed)
    )
    samples: collections.deque = collections.deque(maxlen=args.window)
    temperature = args.temperature_start
    returns: list[float] = []
    evaluations: list[tuple[int, float]] = []
    best, kept = -np.inf, network.export()

    for episode in range(1, args.episodes + 1):
        # play one episode with the current network, recording the search targets
        function = PolicyValueFunction(network.export(), space)
        state = episode_start(env, world, starts, args.exploring_starts)
        moves, tail = self_play_episode(
            model, state, function, settings, temperature, rng, world, args.max_episode_steps
        )
        returns.append(sum(move.reward for move in moves))
        targets = value_targets(moves, args.value_target, args.gamma, tail)
        samples.extend(
            (move.features, move.policy, target)
            for move, target in zip(moves, targets, strict=True)
        )

        # full-batch gradient steps on the recent samples
        x = np.stack([s[0] for s in samples])
        pi = np.stack([s[1] for s in samples]).astype(np.float32)
        v = np.array([s[2] for s in samples], dtype=np.float32)
        for _ in range(args.epochs):
            network.gradient_step(x, pi, v)
        temperature = max(args.temperature_decay * temperature, args.temperature_min)

        # keep the network that acts best on the held-out episodes
        if episode % args.evaluate_every == 0 or episode == args.episodes:
            weights = network.export()
            score = evaluation_return(
                evaluation_env,
                PolicyValueFunction(weights, space),
                settings,
                evaluation_seeds,
                np.random.default_rng(evaluation_search),
            )
            evaluations.append((episode, score))
            if score > best:
                best, kept = score, weights
        if progress is not None and progress(episode, args.episodes):
            break

    info = {
        "seconds": time.perf_counter() - start,
        "episodes": len(returns),
        "evaluations": evaluations,
        "kept_evaluation": float(best),
        "last_returns_mean": float(np.mean(returns[-10:])),
        "args": asdict(args),
    }
    return kept, info
