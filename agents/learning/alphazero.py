"""AlphaZero self-play training on the stationary base environment θ_0 (imports torch).

AlphaZero (Silver et al. 2017) as NS-Gym trains it, with two of its defects fixed: the policy loss
is the cross-entropy between the visit distribution and the network's *logits* (NS-Gym applied
``cross_entropy`` to softmax outputs, a double softmax), and the network trains on a window of
recent self-play samples rather than only the last episode. The loop reads top to bottom:

for each episode: play it with PUCT on the planning model (θ_0) under the current network,
recording ``(features, visit distribution at temperature T, value target)`` per move and
sampling each move from that distribution; the value target is the discounted return from that
move to the episode's end (AlphaZero's z; ``value_target="root_q"``: NS-Gym's visit-weighted
root Q, which learns nothing from sparse rewards until the search itself finds them); then
``epochs`` full-batch Adam steps on the window with
``loss = MSE(v, V_target) + CE(π_target, softmax(logits))`` (weight decay in Adam);
``T <- max(decay * T, T_min)``. The weights kept are those after the episode with the best
moving-average return over the last ``checkpoint_window`` episodes.
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.features import feature_size, features
from ns_pz.agents.learning.networks import PolicyValueNet, seeded_torch
from ns_pz.agents.learning.puct import PolicyValueFunction, model_evaluation, puct_tree

from ns_pz.views import NSGymEnv


def alphazero_loss(
    logits: torch.Tensor,
    values: torch.Tensor,
    policy_targets: torch.Tensor,
    value_targets: torch.Tensor,
) -> torch.Tensor:
    """``MSE(values, value_targets) + CE(policy_targets, softmax(logits))``, batch means.

    Args:
        logits: ``[batch, num_actions]`` raw policy outputs (not probabilities).
        values: ``[batch]``.
        policy_targets: ``[batch, num_actions]`` visit distributions (rows sum to 1).
        value_targets: ``[batch]``.
    """
    cross_entropy = -(policy_targets * F.log_softmax(logits, dim=1)).sum(dim=1).mean()
    return F.mse_loss(values, value_targets) + cross_entropy


def train_alphazero(
    env: NSGymEnv,
    args: AlphaZeroArgs,
    seed: int,
    progress: Callable[[int, int], bool] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Self-play ``args.episodes`` episodes in ``env`` (stationary, θ_0) and train the network.

    ``args`` must have its family defaults filled in (:meth:`AlphaZeroArgs.for_family`).
    Everything random comes from ``seed`` (episodes, searches, move sampling, initialisation).
    ``progress`` is called after every episode with ``(episodes done, args.episodes)``; if it
    returns True, training stops there (the network kept so far is returned).

    Returns:
        The kept network's weights (:class:`PolicyValueFunction` layout) and training figures.
    """
    if args.hidden is None:
        raise ValueError(f"args={args!r} must have hidden filled in (for_family)")
    settings = args.puct_settings()
    space = env.family.observation_space
    num_actions = int(env.action_space.n)  # type: ignore[attr-defined]  # Discrete
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    with seeded_torch(seed):
        network = PolicyValueNet(feature_size(space), args.hidden, num_actions)
        optimizer = torch.optim.Adam(
            network.parameters(), lr=args.learning_rate, weight_decay=args.weight_decay
        )
        samples: collections.deque = collections.deque(maxlen=args.window)
        temperature = args.temperature_start
        returns: list[float] = []
        best_average, kept = -np.inf, network.export()

        observation, _ = env.reset(seed=seed)
        for episode in range(args.episodes):
            # play one episode with the current network, recording the search targets
            function = PolicyValueFunction(network.export(), space)
            episode_return, done, rewards, played = 0.0, False, [], []
            while not done:
                model = env.planning_model()
                evaluate = model_evaluation(function, model)
                tree = puct_tree(model, model.get_state(), rng, evaluate, settings)
                policy = tree.policy_target(temperature)
                played.append((features(space, observation["state"]), policy, tree.value_target()))
                action = int(rng.choice(num_actions, p=policy))
                observation, reward, terminated, truncated, _ = env.step(action)
                episode_return += float(reward)
                rewards.append(float(reward))
                done = terminated or truncated
            returns.append(episode_return)
            if args.value_target == "return":  # z: the discounted return from each move on
                tail = 0.0
                for i in range(len(played) - 1, -1, -1):
                    tail = rewards[i] + args.gamma * tail
                    played[i] = (played[i][0], played[i][1], tail)
            samples.extend(played)
            observation, _ = env.reset()

            # full-batch gradient steps on the recent samples
            x = torch.from_numpy(np.stack([s[0] for s in samples]))
            pi = torch.from_numpy(np.stack([s[1] for s in samples]).astype(np.float32))
            v = torch.tensor([s[2] for s in samples], dtype=torch.float32)
            for _ in range(args.epochs):
                logits, values = network(x)
                loss = alphazero_loss(logits, values, pi, v)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            temperature = max(args.temperature_decay * temperature, args.temperature_min)

            # keep the network of the best moving-average return
            average = float(np.mean(returns[-args.checkpoint_window :]))
            if (
                len(returns) >= min(args.checkpoint_window, args.episodes)
                and average > best_average
            ):
                best_average, kept = average, network.export()
            if progress is not None and progress(episode + 1, args.episodes):
                break

    info = {
        "seconds": time.perf_counter() - start,
        "episodes": len(returns),
        "best_moving_average": float(best_average),
        "last_returns_mean": float(np.mean(returns[-args.checkpoint_window :])),
        "args": asdict(args),
    }
    return kept, info
