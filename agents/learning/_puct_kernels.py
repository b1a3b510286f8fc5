"""Compiled (numba) PUCT for tabular models; imported on first use, never by ``import ns_pz``.

The network is frozen while acting, and a tabular family has finitely many states, so the
policy/value network enters the kernel as a table (``priors[state]``, ``values[state]``) built
once in Python. The kernel performs the same floating-point operations and draws the same random
numbers, in the same order, as :func:`ns_pz.agents.learning.puct.puct_tree` does with that table,
so both paths build the same tree for the same generators. Transitions use the tabular step of
:mod:`ns_pz.agents.search._kernels` (bit-identical to the slip grids' Python step).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from ns_pz.agents.search._kernels import _uniform_index, tabular_step


@numba.njit(cache=True)
def _select(q, priors, n, visits, c, lo, hi, normalise, rng, scores, ties):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """As ``puct._select``: (scaled) Q plus the prior term, uniform among ties."""
    num_actions = q.shape[0]
    root = math.sqrt(1 + n)
    best = -np.inf
    for a in range(num_actions):
        value = q[a]
        if normalise and hi > lo:
            value = (value - lo) / (hi - lo)
        scores[a] = value + c * priors[a] * root / (1 + visits[a])
        if scores[a] > best:
            best = scores[a]
    count = 0
    for a in range(num_actions):
        if scores[a] == best:
            ties[count] = a
            count += 1
    if count == 1:
        return ties[0]
    return ties[_uniform_index(rng, count)]


@numba.njit(cache=True)
def puct_tabular(  # type: ignore[no-untyped-def]  # pragma: no cover
    data,
    root,
    root_priors,
    priors_table,
    values_table,
    iterations,
    depth,
    c,
    gamma,
    normalise,
    model_rng,
    search_rng,
):
    """PUCT over an outcome table; returns ``(root visits, root Q, nodes, simulated steps)``.

    Node ``i`` (0 is the root) has ``state[i]``, ``terminal[i]``, ``value[i]``, priors, N, W and
    Q; its children under action ``a`` form a linked list from ``first_child[i, a]``.
    """
    num_actions = priors_table.shape[1]
    capacity = iterations + 1
    state = np.zeros(capacity, dtype=np.int64)
    terminal = np.zeros(capacity, dtype=np.bool_)
    value = np.zeros(capacity)
    priors = np.zeros((capacity, num_actions))
    n = np.zeros(capacity, dtype=np.int64)
    visits = np.zeros((capacity, num_actions), dtype=np.int64)
    w = np.zeros((capacity, num_actions))
    q = np.zeros((capacity, num_actions))
    first_child = np.full((capacity, num_actions), -1, dtype=np.int64)
    next_sibling = np.full(capacity, -1, dtype=np.int64)
    path_nodes = np.empty(capacity + depth + 1, dtype=np.int64)
    path_actions = np.empty(capacity + depth + 1, dtype=np.int64)
    path_rewards = np.empty(capacity + depth + 1)
    scores = np.empty(num_actions)
    ties = np.empty(num_actions, dtype=np.int64)
    current = np.empty(1)
    sampled = np.empty(1)
    state[0] = root
    value[0] = values_table[root]
    priors[0] = root_priors
    q[0, :] = value[0]
    num_nodes = 1
    simulated = 0
    lo = np.inf
    hi = -np.inf
    for _ in range(iterations):
        node = 0
        length = 0
        level = 0
        leaf = 0.0
        while True:
            action = _select(
                q[node],
                priors[node],
                n[node],
                visits[node],
                c,
                lo,
                hi,
                normalise,
                search_rng,
                scores,
                ties,
            )
            current[0] = state[node]
            reward, done = tabular_step(data, current, sampled, action, model_rng)
            simulated += 1
            path_nodes[length] = node
            path_actions[length] = action
            path_rewards[length] = reward
            length += 1
            next_state = int(sampled[0])
            child = first_child[node, action]
            last = -1
            while child >= 0 and state[child] != next_state:
                last = child
                child = next_sibling[child]
            if child < 0:
                child = num_nodes
                num_nodes += 1
                state[child] = next_state
                if last < 0:
                    first_child[node, action] = child
                else:
                    next_sibling[last] = child
                if done:
                    terminal[child] = True
                else:
                    value[child] = values_table[next_state]
                    priors[child] = priors_table[next_state]
                    q[child, :] = value[child]
                leaf = value[child]
                break
            node = child
            if terminal[node] or level == depth:
                leaf = value[node]
                break
            level += 1
        for i in range(length - 1, -1, -1):
            m = path_nodes[i]
            a = path_actions[i]
            leaf = path_rewards[i] + gamma * leaf
            visits[m, a] += 1
            w[m, a] += leaf
            q[m, a] = w[m, a] / visits[m, a]
            n[m] += 1
            if normalise:
                lo = min(lo, q[m, a])
                hi = max(hi, q[m, a])
    return visits[0].copy(), q[0].copy(), num_nodes, simulated
