"""Compiled (numba) UCT and rollouts; imported on first use, never by ``import ns_pz``.

One UCT kernel serves every family with a compiled step. States are ``float64`` vectors (a grid
cell is a 1-vector holding its index), and the family's dynamics are reached through
:func:`family_step`, which numba resolves at compile time from the *type* of the ``data``
argument: each family defines a ``NamedTuple`` of what its step needs (θ-derived arrays and
constants) and registers a compiled step for that class with :func:`register_step`. Because the
kernel is specialised by that type (not by a function object), its machine code is cached on disk
(``cache=True``) and loaded in later processes without compiling.

Random numbers come from the caller's ``numpy.random.Generator`` objects, which numba advances
in place: a compiled search consumes exactly the draws the reference Python search consumes, in
the same order, so both give bit-identical trees for the same seeds. Every random choice is one
``rng.random()`` draw (an index ``int(u * n)``), never ``rng.integers``.

Numba's cache index of a kernel lists every type it was compiled for, and a later process must be
able to import each of them to read the index. So only data classes defined in ``ns_pz``
modules reach this module's on-disk cache; data classes defined elsewhere (a script, a test) use
a second, uncached copy of this module (:func:`ns_pz.agents.search.compiled.kernels_for`), and
compile once per process.

The machine code is cached in a user cache folder, never in the package
(:mod:`ns_pz.agents.search.numba_cache`; ``NS_PZ_CACHE_DIR`` moves it). Numba caches the kernel
under this source file: editing a registered step in another module does not invalidate it,
nor does changing a step's ``deterministic`` flag (the kernels read it when they compile).
After changing a compiled step or its flag, delete that folder (or point ``NS_PZ_CACHE_DIR``
at a fresh one); the tests that compare the compiled and reference paths catch a stale cache.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from ns_pz.agents.search import numba_cache
from ns_pz.agents.search._pcg64 import inline_streams  # noqa: F401  # for the callers
from ns_pz.agents.search.compiled import (
    CUMULATIVE,
    FIELDS,
    NEXT_OFFSET,
    NEXT_STATE,
    REWARD,
    TERMINAL,
    CartPoleData,
    TabularData,
)
from numba.core import types
from numba.extending import overload

numba_cache.install()  # before the first cache=True below: caches go to a user folder

CACHE = __name__ == "ns_pz.agents.search._kernels"
"""Whether this copy caches machine code on disk (see :func:`compiled.kernels_for`)."""

_STEPS: dict[type, Any] = {}
_ROLLOUTS: dict[type, Any] = {}
_DETERMINISTIC: set[type] = set()


@numba.njit(cache=CACHE)
def ready(n: int) -> int:
    """``n + 1``: the smallest cached kernel, whose first load starts numba's machinery.

    A process pays that start (about 0.3 s on the development machine) at the first cached
    kernel it loads, whichever it is; :func:`~ns_pz.agents.search.compiled.warm_up` pays it
    with this one.
    """
    return n + 1


def register_step(
    data_cls: type, step: Any, rollout: Any = None, deterministic: bool = False
) -> None:
    """Make ``step`` (and ``rollout``) the compiled dynamics of ``data`` arguments of ``data_cls``.

    Args:
        data_cls: A ``NamedTuple`` class (numba types its instances structurally).
        step: A ``numba.njit(cache=True, inline="always")`` function ``step(data, state, out,
            action, rng) -> (reward, terminal)`` that writes the next state into ``out`` (a
            ``float64`` vector) and draws its randomness with ``rng.random()`` exactly as the
            family's Python ``step`` does (``rng`` may be a ``PCG64Stream``, which has no
            other method).
        rollout: Optional hot loop with the signature of :func:`generic_rollout`. The generic
            one calls ``step`` per transition; a family-specific loop that reads ``data`` once
            avoids numba's per-call reference counting of the arrays in ``data`` (tabular:
            15-50 instead of ~150 ns per step) and keeps the state in registers. It must
            consume random numbers as the generic one.
        deterministic: ``step`` never draws from ``rng`` and its outcome is a function of
            ``(state, action)``. A search then walks an edge of its tree it has already
            simulated without simulating it again (the same next state, reward and end): the
            same tree for the same draws. On CartPole with γ = 1, where UCT's paths run deep,
            it alone took a decision (m=300, d=500) from 3.4 to 2.0 ms.
    """
    _STEPS[data_cls] = step
    if rollout is not None:
        _ROLLOUTS[data_cls] = rollout
    if deterministic:
        _DETERMINISTIC.add(data_cls)
    else:
        _DETERMINISTIC.discard(data_cls)


def family_is_deterministic(data: Any) -> bool:
    """Stub resolved by numba to a constant: whether ``type(data)``'s step is deterministic."""
    raise NotImplementedError("family_is_deterministic only runs inside compiled code")


@overload(family_is_deterministic, jit_options={"cache": CACHE}, inline="always")  # type: ignore[typeddict-unknown-key]
def _family_is_deterministic_overload(data: Any) -> Any:
    if not isinstance(data, types.BaseNamedTuple):
        return None
    answer = data.instance_class in _DETERMINISTIC  # type: ignore[attr-defined]

    def impl(data: Any) -> bool:  # pragma: no cover
        return answer

    return impl


def family_step(data: Any, state: Any, out: Any, action: Any, rng: Any) -> Any:
    """Stub resolved by numba to the step registered for ``type(data)``."""
    raise NotImplementedError("family_step only runs inside compiled code")


@overload(family_step, jit_options={"cache": CACHE}, inline="always")  # type: ignore[typeddict-unknown-key]
def _family_step_overload(data: Any, state: Any, out: Any, action: Any, rng: Any) -> Any:
    if not isinstance(data, types.BaseNamedTuple):
        return None
    step = _STEPS.get(data.instance_class)  # type: ignore[attr-defined]
    if step is None:
        return None

    def impl(data: Any, state: Any, out: Any, action: Any, rng: Any) -> Any:  # pragma: no cover
        return step(data, state, out, action, rng)

    return impl


def family_rollout(
    data: Any,
    state: Any,
    num_actions: Any,
    depth: Any,
    gamma: Any,
    model_rng: Any,
    search_rng: Any,
) -> Any:
    """Stub resolved by numba to the registered rollout, or :func:`generic_rollout`."""
    raise NotImplementedError("family_rollout only runs inside compiled code")


@overload(family_rollout, jit_options={"cache": CACHE})  # type: ignore[typeddict-unknown-key]
def _family_rollout_overload(
    data: Any,
    state: Any,
    num_actions: Any,
    depth: Any,
    gamma: Any,
    model_rng: Any,
    search_rng: Any,
) -> Any:
    data_cls = getattr(data, "instance_class", None)  # numba's NamedTuple types have it
    if not isinstance(data, types.BaseNamedTuple) or data_cls not in _STEPS:
        return None
    loop = _ROLLOUTS.get(data_cls, generic_rollout)

    def impl(  # pragma: no cover
        data: Any,
        state: Any,
        num_actions: Any,
        depth: Any,
        gamma: Any,
        model_rng: Any,
        search_rng: Any,
    ) -> Any:
        return loop(data, state, num_actions, depth, gamma, model_rng, search_rng)

    return impl


@numba.njit(cache=CACHE, inline="always")
def _uniform_index(rng, n):  # type: ignore[no-untyped-def]  # pragma: no cover
    index = int(rng.random() * n)
    return index if index < n else n - 1


@numba.njit(cache=CACHE)
def generic_rollout(data, state, num_actions, depth, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """Uniform random actions from ``state`` for up to ``depth`` steps or until terminal.

    Each step draws the action from ``search_rng`` first, then calls the family's step (which
    draws from ``model_rng``). Rewards are discounted by ``gamma`` per step from 1.

    Returns:
        ``(discounted return, steps taken)``.
    """
    current = state.copy()
    nxt = np.empty_like(current)
    dim = current.shape[0]
    total = 0.0
    discount = 1.0
    steps = 0
    while steps < depth:
        action = _uniform_index(search_rng, num_actions)
        reward, done = family_step(data, current, nxt, action, model_rng)
        total += discount * reward
        discount *= gamma
        steps += 1
        if done:
            break
        for j in range(dim):
            current[j] = nxt[j]
    return total, steps


# --- built-in families ----------------------------------------------------------------------
@numba.njit(cache=CACHE)
def pack_table(probs, next_states, rewards, terminals):  # type: ignore[no-untyped-def]  # pragma: no cover
    """:class:`~.compiled.TabularData`'s array from an outcome table's four arrays.

    Each row's cumulative probability is the running total of its probabilities in order (the
    Python model's), infinite from the last outcome of positive probability on.

    Returns:
        ``(table, s, a)``: ``s, a`` are ``-1, -1``, or the first row that is no distribution to
        draw from (a negative or NaN probability, or none positive); the table is then unfinished.
    """
    num_states, num_actions, num_outcomes = probs.shape
    table = np.empty((num_states, num_actions, num_outcomes, FIELDS))
    offsets = table.reshape(-1).view(np.int64)
    state_length = num_actions * num_outcomes * FIELDS
    for s in range(num_states):
        for a in range(num_actions):
            total = 0.0
            last = -1
            for k in range(num_outcomes):
                p = probs[s, a, k]
                if not p >= 0.0:
                    return table, s, a
                if p > 0.0:
                    last = k
                total += p
                table[s, a, k, CUMULATIVE] = total
                table[s, a, k, NEXT_STATE] = next_states[s, a, k]
                table[s, a, k, REWARD] = rewards[s, a, k]
                table[s, a, k, TERMINAL] = 1.0 if terminals[s, a, k] else 0.0
                entry = ((s * num_actions + a) * num_outcomes + k) * FIELDS
                offsets[entry + NEXT_OFFSET] = next_states[s, a, k] * state_length
            if last < 0:
                return table, s, a
            for k in range(last, num_outcomes):
                table[s, a, k, CUMULATIVE] = np.inf
    return table, -1, -1


@numba.njit(cache=CACHE, inline="always")
def tabular_step(data, state, out, action, rng):  # type: ignore[no-untyped-def]  # pragma: no cover
    """One uniform draw picks the first outcome whose cumulative probability exceeds it.

    The scan always stops: the last outcome of positive probability has an infinite one.
    """
    s = int(state[0])
    table = data.table
    u = rng.random()
    pick = 0
    for k in range(table.shape[2]):
        if u < table[s, action, k, CUMULATIVE]:
            pick = k
            break
    out[0] = table[s, action, pick, NEXT_STATE]
    return table[s, action, pick, REWARD], table[s, action, pick, TERMINAL] != 0.0


@numba.njit(cache=CACHE)
def tabular_rollout(data, state, num_actions, depth, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """:func:`generic_rollout` with :func:`tabular_step` written into the loop, branch-free.

    The outcome is the number of cumulative probabilities at or below the draw (they never
    decrease, so these come first, and the infinite one never counts): the same outcome as the
    scan's, without a branch on the draw, which the CPU would often mispredict where the
    outcome is truly random. The walk reads the flattened table at unsigned offsets (numba adds
    no test for negative indices) and goes from state to state through ``NEXT_OFFSET``, so the
    table must be :func:`pack_table`'s (``FIELDS`` wide, its offsets computed from its own
    shape); the first state's offset is computed from that shape too.

    The outcomes' stride is read from the table's shape all the same, not compiled in as
    ``FIELDS``: with a constant stride LLVM turns the count into a vector gather, whose latency
    lies on the chain from one step to the next (11.4 against 7.7 ns a CliffWalking step).
    """
    table = data.table
    _, table_actions, num_outcomes, fields = table.shape
    flat = table.reshape(-1)
    offsets = flat.view(np.uint64)
    stride = np.uint64(fields)
    action_length = np.uint64(num_outcomes) * stride
    start = np.uint64(int(state[0])) * np.uint64(table_actions) * action_length
    total = 0.0
    discount = 1.0
    steps = 0
    while steps < depth:
        row = start + np.uint64(_uniform_index(search_rng, num_actions)) * action_length
        u = model_rng.random()
        pick = np.uint64(0)
        for k in range(num_outcomes):
            pick += np.uint64(flat[row + np.uint64(k) * stride + np.uint64(CUMULATIVE)] <= u)
        entry = row + pick * stride
        total += discount * flat[entry + np.uint64(REWARD)]
        discount *= gamma
        steps += 1
        if flat[entry + np.uint64(TERMINAL)] != 0.0:
            break
        start = offsets[entry + np.uint64(NEXT_OFFSET)]
    return total, steps


register_step(TabularData, tabular_step, tabular_rollout)


@numba.njit(cache=CACHE, inline="always")
def _cartpole_motion(data, x, x_dot, angle, angle_dot, action):  # type: ignore[no-untyped-def]  # pragma: no cover
    """One step of CartPole's motion: ``(x, x_dot, angle, angle_dot, terminal)`` after it.

    The same floating-point operations, in the same order, as ``CartPoleFamily.step``.
    """
    force = data.force_mag if action == 1 else -data.force_mag
    cos = math.cos(angle)
    sin = math.sin(angle)
    total_mass = data.masspole + data.masscart
    polemass_length = data.masspole * data.length
    temp = (force + polemass_length * (angle_dot * angle_dot) * sin) / total_mass
    angle_acc = (data.gravity * sin - cos * temp) / (
        data.length * (4.0 / 3.0 - data.masspole * (cos * cos) / total_mass)
    )
    x_acc = temp - polemass_length * angle_acc * cos / total_mass
    tau = data.tau
    if data.euler:
        x = x + tau * x_dot
        x_dot = x_dot + tau * x_acc
        angle = angle + tau * angle_dot
        angle_dot = angle_dot + tau * angle_acc
    else:
        x_dot = x_dot + tau * x_acc
        x = x + tau * x_dot
        angle_dot = angle_dot + tau * angle_acc
        angle = angle + tau * angle_dot
    terminal = (
        x < -data.x_threshold
        or x > data.x_threshold
        or angle < -data.theta_threshold
        or angle > data.theta_threshold
    )
    return x, x_dot, angle, angle_dot, terminal


@numba.njit(cache=CACHE, inline="always")
def cartpole_step(data, state, out, action, rng):  # type: ignore[no-untyped-def]  # pragma: no cover
    """:func:`_cartpole_motion` over state vectors; reward 1 every step (draws nothing)."""
    out[0], out[1], out[2], out[3], terminal = _cartpole_motion(
        data, state[0], state[1], state[2], state[3], action
    )
    return 1.0, terminal


@numba.njit(cache=CACHE)
def cartpole_rollout(data, state, num_actions, depth, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """:func:`generic_rollout` for CartPole with the state in four locals, not a vector."""
    x, x_dot, angle, angle_dot = state[0], state[1], state[2], state[3]
    total = 0.0
    discount = 1.0
    steps = 0
    while steps < depth:
        action = _uniform_index(search_rng, num_actions)
        x, x_dot, angle, angle_dot, terminal = _cartpole_motion(
            data, x, x_dot, angle, angle_dot, action
        )
        total += discount * 1.0  # CartPole's reward
        discount *= gamma
        steps += 1
        if terminal:
            break
    return total, steps


register_step(CartPoleData, cartpole_step, cartpole_rollout, deterministic=True)


# --- the search -----------------------------------------------------------------------------
@numba.njit(cache=CACHE)
def rollout(data, state, num_actions, depth, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """The family's rollout (see :func:`generic_rollout`): ``(discounted return, steps)``."""
    return family_rollout(data, state, num_actions, depth, gamma, model_rng, search_rng)


@numba.njit(cache=CACHE)
def repeated_rollouts(data, state, count, num_actions, depth, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``count`` rollouts from ``state`` in one call: ``(returns[count], total steps)``."""
    returns = np.empty(count)
    total_steps = 0
    for i in range(count):
        value, steps = family_rollout(data, state, num_actions, depth, gamma, model_rng, search_rng)
        returns[i] = value
        total_steps += steps
    return returns, total_steps


@numba.njit(cache=CACHE, inline="always")
def _find_child(first_child, next_sibling, states, node, action, sampled):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``(child, last)``: the child of ``(node, action)`` whose state vector equals ``sampled``.

    Children of a chance node form a linked list from ``first_child[node, action]`` through
    ``next_sibling``; ``child`` is -1 when none matches, and ``last`` is then the list's last
    node (-1 for an empty list), which a new child is linked after.

    It returns from inside its loop rather than breaking out of two: with the breaks, numba
    kept counting references to the three arrays (atomic operations) at every step of a walk.
    """
    child = first_child[node, action]
    last = -1
    dim = sampled.shape[0]
    while child >= 0:
        j = 0
        while j < dim and states[child, j] == sampled[j]:
            j += 1
        if j == dim:
            return child, last
        last = child
        child = next_sibling[child]
    return child, last


@numba.njit(cache=CACHE)
def uct(data, root, num_actions, iterations, depth, c, gamma, model_rng, search_rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """UCT as ``ns_pz.agents.search.mcts.reference_uct``, over arrays.

    Node ``i`` (0 is the root) has ``states[i]``, ``terminal[i]``, ``node_visits[i]``,
    ``visits[i, a]`` and ``q[i, a]``; its children under action ``a`` form a linked list from
    ``first_child[i, a]`` through ``next_sibling``. At most one node is created per iteration.
    For a deterministic family (:func:`register_step`) an edge already in the tree is walked
    from ``edge_reward`` and its one child, not simulated again; it still counts as a
    simulated step, so the count matches the reference search's.

    The walk down the tree keeps numba's reference counting out: an array view
    (``states[node]``, ``q[node]``), or an array handed to an inlined helper whose loops the
    pruning of that counting cannot see through, costs an atomic increment and decrement of
    the array's counter at every step, more than the rest of the step. So a node's state is
    copied into ``current`` for the family's step, the selection is written out here (as a
    helper it kept ``ties`` counted), and :func:`_find_child` returns from its loop (the LLVM IR
    of this kernel shows no count in the walk). A CliffWalking decision (m=1000) took 2.7
    against 1.9-2.0 ms; an ADA-MCTS trial, whose trees are deeper, 2.6-2.9 against 1.4-1.5
    CPU-s.

    Returns:
        ``(parent, parent_action, states, terminal, node_visits, visits, q, num_nodes,
        simulated_steps)`` with the arrays cut to ``num_nodes`` rows.
    """
    capacity = iterations + 1
    dim = root.shape[0]
    states = np.empty((capacity, dim))
    terminal = np.zeros(capacity, dtype=np.bool_)
    node_visits = np.zeros(capacity, dtype=np.int64)
    visits = np.zeros((capacity, num_actions), dtype=np.int64)
    q = np.zeros((capacity, num_actions))
    first_child = np.full((capacity, num_actions), -1, dtype=np.int64)
    next_sibling = np.full(capacity, -1, dtype=np.int64)
    parent = np.full(capacity, -1, dtype=np.int64)
    parent_action = np.full(capacity, -1, dtype=np.int64)
    path_nodes = np.empty(capacity, dtype=np.int64)
    path_actions = np.empty(capacity, dtype=np.int64)
    path_rewards = np.empty(capacity)
    ties = np.empty(num_actions, dtype=np.int64)
    current = np.empty(dim)
    sampled = np.empty(dim)
    edge_reward = np.zeros((capacity, num_actions))  # read only for a deterministic family
    deterministic = family_is_deterministic(data)
    states[0] = root
    num_nodes = 1
    simulated = 0
    for _ in range(iterations):
        node = 0
        length = 0
        done = False
        while not terminal[node]:
            untried = 0  # UCB1, untried actions first; see the docstring for why not a helper
            for a in range(num_actions):
                if visits[node, a] == 0:
                    ties[untried] = a
                    untried += 1
            if untried > 0:
                action = ties[_uniform_index(search_rng, untried)]
            else:
                log_n = math.log(node_visits[node])
                best = -np.inf
                count = 0
                for a in range(num_actions):
                    score = q[node, a] + c * math.sqrt(log_n / visits[node, a])
                    if score > best:
                        best = score
                        ties[0] = a
                        count = 1
                    elif score == best:
                        ties[count] = a
                        count += 1
                action = ties[0] if count == 1 else ties[_uniform_index(search_rng, count)]
            known = deterministic and first_child[node, action] >= 0
            if known:  # the edge's one outcome, as simulated when it was added
                child = first_child[node, action]
                last = -1
                reward = edge_reward[node, action]
                done = terminal[child]
            else:
                for j in range(dim):
                    current[j] = states[node, j]
                reward, done = family_step(data, current, sampled, action, model_rng)
            simulated += 1
            path_nodes[length] = node
            path_actions[length] = action
            path_rewards[length] = reward
            length += 1
            if not known:
                child, last = _find_child(first_child, next_sibling, states, node, action, sampled)
            new = child < 0
            if new:
                child = num_nodes
                num_nodes += 1
                states[child] = sampled
                terminal[child] = done
                parent[child] = node
                parent_action[child] = action
                edge_reward[node, action] = reward
                if last < 0:
                    first_child[node, action] = child
                else:
                    next_sibling[last] = child
            node = child
            if new or done:
                break
        value = 0.0
        if not done:
            value, steps = family_rollout(
                data, states[node], num_actions, depth, gamma, model_rng, search_rng
            )
            simulated += steps
        for i in range(length - 1, -1, -1):
            n = path_nodes[i]
            a = path_actions[i]
            value = path_rewards[i] + gamma * value
            node_visits[n] += 1
            visits[n, a] += 1
            q[n, a] += (value - q[n, a]) / visits[n, a]
    return (
        parent[:num_nodes],
        parent_action[:num_nodes],
        states[:num_nodes],
        terminal[:num_nodes],
        node_visits[:num_nodes],
        visits[:num_nodes],
        q[:num_nodes],
        num_nodes,
        simulated,
    )
