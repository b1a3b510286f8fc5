"""Double DQN (van Hasselt et al. 2016) trained on the stationary base env θ_0 (imports torch).

The training loop reads top to bottom like cleanrl's ``dqn.py``; the one
thing that makes it *Double* DQN is :func:`double_dqn_target`: the online network chooses the
next action, the target network evaluates it (NS-Gym's ``DDQN`` uses the vanilla
``max_a' Q_target`` target, and in practice no separate target network at all).

Departures from NS-Gym's loop, each for a reason: ε decays linearly over a fraction of the
training *steps* (cleanrl) rather than ×0.999 per episode, so a short quick-size run still ends
greedy; truncation at ``max_episode_steps`` is not treated as termination (the target
bootstraps through it). The loss is the MSE of the spec, optimised by Adam with weight decay.

Acting with the trained network needs numpy only: :class:`ns_pz.agents.learning.agents.DDQNAgent`.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.features import feature_size, features
from ns_pz.agents.learning.networks import LayerCalls, export, mlp, seeded_torch
from ns_pz.agents.learning.replay import Batch, ReplayBuffer
from ns_pz.agents.learning.seeding import training_seeds

from ns_pz.views import NSGymEnv

#: A Q-network as the updates take it: the module, or its :class:`LayerCalls` (the same
#: arithmetic, faster to call).
QNet = torch.nn.Module | LayerCalls


def dqn_target(
    next_q_target: torch.Tensor, rewards: torch.Tensor, terminated: torch.Tensor, gamma: float
) -> torch.Tensor:
    """The vanilla DQN target ``r + γ (1 - done) max_a' Q_target(s', a')`` (for comparison).

    Args:
        next_q_target: ``[batch, num_actions]`` target-network values of the next states.
        rewards: ``[batch]``.
        terminated: ``[batch]``, 1.0 where the transition ended the episode.
        gamma: Discount.
    """
    return rewards + gamma * (1.0 - terminated) * next_q_target.max(dim=1).values


def double_dqn_target(
    next_q_online: torch.Tensor,
    next_q_target: torch.Tensor,
    rewards: torch.Tensor,
    terminated: torch.Tensor,
    gamma: float,
) -> torch.Tensor:
    """The Double-DQN target ``r + γ (1 - done) Q_target(s', argmax_a' Q_online(s', a'))``.

    Args:
        next_q_online: ``[batch, num_actions]`` online-network values of the next states (they
            choose the action).
        next_q_target: ``[batch, num_actions]`` target-network values (they evaluate it).
        rewards: ``[batch]``.
        terminated: ``[batch]``, 1.0 where the transition ended the episode.
        gamma: Discount.
    """
    chosen = next_q_online.argmax(dim=1, keepdim=True)
    evaluated = next_q_target.gather(1, chosen).squeeze(1)
    return rewards + gamma * (1.0 - terminated) * evaluated


def train_ddqn(
    env: NSGymEnv,
    args: DDQNArgs,
    seed: int,
    progress: Callable[[int, int], bool] | None = None,
) -> tuple[dict[str, np.ndarray], dict]:
    """Train a Double DQN in ``env`` (a stationary env at θ_0) for ``args.total_steps`` steps.

    Everything random comes from ``seed``, split by :func:`training_seeds` into independent
    streams: the env's episodes, ε-greedy and replay sampling (a numpy generator), the network
    initialisation (a forked torch generator). Torch runs on one thread (the benchmark's
    workers use the other cores).

    Args:
        env: The stationary training environment.
        args: The settings, family defaults filled in.
        seed: Everything random comes from it.
        progress: Called after every step with ``(steps done, args.total_steps)``; if it returns
            True, training stops there and the network so far is returned (``bench estimate``
            times a few steps this way).

    Returns:
        The Q-network's weights (``q.i.weight``/``q.i.bias``, :class:`NumpyMLP` layout) and
        training figures (seconds, episodes, mean return of the last 20 training episodes).
    """
    space = env.family.observation_space
    num_actions = int(env.action_space.n)  # type: ignore[attr-defined]  # Discrete
    rng, env_seed, torch_seed = training_seeds(seed)
    start = time.perf_counter()
    with seeded_torch(torch_seed):
        q_network, target_network, optimizer = new_learner(feature_size(space), num_actions, args)
        buffer = ReplayBuffer(args.buffer_size, feature_size(space))
        # the networks' forward passes without nn.Module's dispatch (the same arithmetic)
        online, target = LayerCalls(q_network), LayerCalls(target_network)
        acting = LayerCalls(q_network, detached=True)
        returns: list[float] = []
        episode_return = 0.0

        observation, _ = env.reset(seed=env_seed)
        x = features(space, observation["state"])
        for step in range(args.total_steps):
            # ε-greedy action, ε decaying linearly to its floor
            fraction = min(1.0, step / max(1.0, args.exploration_fraction * args.total_steps))
            epsilon = args.epsilon_start + fraction * (args.epsilon_end - args.epsilon_start)
            if rng.random() < epsilon:
                action = int(rng.integers(num_actions))
            else:
                action = int(acting(torch.from_numpy(x)).argmax())

            observation, reward, terminated, truncated, _ = env.step(action)
            next_x = features(space, observation["state"])
            buffer.add(x, action, float(reward), next_x, terminated)
            x = next_x
            episode_return += float(reward)
            if terminated or truncated:
                returns.append(episode_return)
                episode_return = 0.0
                observation, _ = env.reset()
                x = features(space, observation["state"])

            # a gradient step every `train_every` steps once the buffer holds a batch
            if step >= args.learning_starts and step % args.train_every == 0:
                batch = buffer.sample(args.batch_size, rng)
                gradient_step(online, target, optimizer, batch, args)
            if progress is not None and progress(step + 1, args.total_steps):
                break

    info: dict[str, Any] = {
        "seconds": time.perf_counter() - start,
        "episodes": len(returns),
        "last_returns_mean": float(np.mean(returns[-20:])) if returns else None,
        "args": asdict(args),
    }
    return export(q_network, "q"), info


def new_learner(
    inputs: int, num_actions: int, args: DDQNArgs
) -> tuple[torch.nn.Sequential, torch.nn.Sequential, torch.optim.Optimizer]:
    """A fresh online network, a separate target network equal to it, and Adam on the online one.

    Draws the initial weights from torch's global generator (seed it first: ``seeded_torch``).

    Raises:
        ValueError: ``args.hidden`` is None (fill it in with :meth:`DDQNArgs.for_family`).
    """
    if args.hidden is None:
        raise ValueError(f"args.hidden={args.hidden!r} must be filled in (DDQNArgs.for_family)")
    q_network = mlp(inputs, args.hidden, num_actions)
    target_network = copy.deepcopy(q_network)
    optimizer = torch.optim.Adam(
        q_network.parameters(), lr=args.learning_rate, weight_decay=args.weight_decay
    )
    return q_network, target_network, optimizer


def td_loss(online: QNet, target: QNet, batch: Batch, gamma: float) -> torch.Tensor:
    """The mean squared error between ``Q_online(s, a)`` and the Double-DQN target of ``batch``.

    The target (no gradient) takes the next action from ``online`` and its value from
    ``target`` (:func:`double_dqn_target`).
    """
    next_features = torch.from_numpy(batch.next_features)
    with torch.no_grad():
        y = double_dqn_target(
            online(next_features),
            target(next_features),
            torch.from_numpy(batch.rewards),
            torch.from_numpy(batch.terminated),
            gamma,
        )
    q_taken = online(torch.from_numpy(batch.features))
    q_taken = q_taken.gather(1, torch.from_numpy(batch.actions)[:, None]).squeeze(1)
    return F.mse_loss(q_taken, y)


def gradient_step(
    online: QNet,
    target: QNet,
    optimizer: torch.optim.Optimizer,
    batch: Batch,
    args: DDQNArgs,
) -> float:
    """One Adam step on :func:`td_loss`, then the Polyak update of ``target`` (rate ``args.tau``).

    Returns:
        The loss before the step.
    """
    loss = td_loss(online, target, batch, args.gamma)
    for group in optimizer.param_groups:  # zero_grad(set_to_none=True) without its profiler
        for parameter in group["params"]:  # scope, a tenth of a fine-tuning's step
            parameter.grad = None
    loss.backward()
    optimizer.step()
    soft_update(target, online, args.tau)
    return loss.item()


def soft_update(target: QNet, online: QNet, tau: float) -> None:
    """``target <- tau * online + (1 - tau) * target``, parameter by parameter."""
    with torch.no_grad():
        for t, o in zip(target.parameters(), online.parameters(), strict=True):
            t.mul_(1.0 - tau).add_(o, alpha=tau)
