"""Compiled (numba) PUCT; imported on first use, never by ``import ns_pz``.

Two kernels. :func:`puct_tabular`: the network is frozen while acting, and a tabular family has
finitely many states, so the policy/value network enters the kernel as a table
(``priors[state]``, ``values[state]``) built once in Python; transitions use the tabular step of
:mod:`ns_pz.agents.search._kernels` (bit-identical to the slip grids' Python step).
:func:`puct_vector`: any family with a registered compiled step over state vectors (CartPole),
the network evaluated inside the kernel on each new node's state (:func:`network_into`, from the
weights packed by :meth:`ns_pz.agents.learning.puct.PolicyValueFunction.packed`), transitions
through ``family_step``.

Each kernel performs the same floating-point operations and draws the same random numbers, in
the same order, as :func:`ns_pz.agents.learning.puct.puct_tree`'s Python path, so both build the
same tree for the same generators. For the network that takes one more step: a matrix product
rounds differently in BLAS than in a loop, so where numba is installed the Python path's
:class:`~ns_pz.agents.learning.puct.VectorEvaluation` calls :func:`network` (this module's
forward pass) rather than numpy's.

Both kernels write PUCT's selection (``puct._select``) out in their walk rather than call a
helper, and copy a node's state or row rather than take a view of it: a view, or an array handed
to an inlined helper with loops, makes numba count references to the array (an atomic increment
and decrement of its counter) at every edge, which its pruning of those counts does not remove
(checked in the kernels' LLVM IR). CartPole's PUCT decision took 0.69 against 0.74-0.75 ms.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from ns_pz.agents.search._kernels import (
    _find_child,
    _uniform_index,
    family_is_deterministic,
    family_step,
    tabular_step,
)
from numba.core import cgutils, types
from numba.core.errors import TypingError
from numba.extending import intrinsic


@numba.njit(cache=True, inline="always")
def _backup(path_nodes, path_actions, path_rewards, length, leaf, gamma, n, visits, w, q, lo, hi):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """Back ``leaf`` up the path (``G <- r + γ G``); ``(lo, hi)`` widened by the new Q values."""
    for i in range(length - 1, -1, -1):
        m = path_nodes[i]
        a = path_actions[i]
        leaf = path_rewards[i] + gamma * leaf
        visits[m, a] += 1
        w[m, a] += leaf
        q[m, a] = w[m, a] / visits[m, a]
        n[m] += 1
        lo = min(lo, q[m, a])
        hi = max(hi, q[m, a])
    return lo, hi


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
            sqrt_n = math.sqrt(1 + n[node])  # puct._select, written out (module docstring)
            best = -np.inf
            for a in range(num_actions):
                scaled = q[node, a]
                if normalise and hi > lo:
                    scaled = (scaled - lo) / (hi - lo)
                scores[a] = scaled + c * priors[node, a] * sqrt_n / (1 + visits[node, a])
                if scores[a] > best:
                    best = scores[a]
            count = 0
            for a in range(num_actions):
                if scores[a] == best:
                    ties[count] = a
                    count += 1
            action = ties[0] if count == 1 else ties[_uniform_index(search_rng, count)]
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
        lo, hi = _backup(
            path_nodes, path_actions, path_rewards, length, leaf, gamma, n, visits, w, q, lo, hi
        )
    return visits[0].copy(), q[0].copy(), num_nodes, simulated


# --- a network inside the kernel: vector states -----------------------------------------------
_LANES = 8
"""Doubles in one vector register of :func:`_block_sums` (AVX-512's; two AVX2 registers)."""
_VECTORS = 4
"""Vectors of accumulators :func:`_block_sums` keeps in registers at once."""
BLOCK = _LANES * _VECTORS
"""Outputs of a layer that :func:`_block_sums` sums at once."""


@intrinsic
def _block_sums(typingctx, weights, start, stride, x, nonzero, count, acc, first):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``acc[first + j] = Σ_k x[i_k] · weights[start + i_k · stride + j]`` for ``j < BLOCK``.

    ``i_k = nonzero[k]`` for ``k < count``; each of the ``BLOCK`` sums starts at +0.0 and adds
    its products one by one in ``k``'s order, a multiplication and then an addition (not fused),
    as :func:`_dense`'s loop does: the same bits. Written in LLVM's vector types because numba's
    loop keeps the sums in memory (a load and a store of each per input), and LLVM promotes the
    accumulators here to registers: the trunk's 128 x 128 layer took 0.52 against 0.95 µs on
    the development machine.

    All four arrays must be C-contiguous (``weights``, ``x`` and ``acc`` float64, ``nonzero``
    int64), which the compiler checks. Nothing checks the bounds (numba's bounds checking does
    not reach into this code): the caller guarantees ``weights`` holds ``BLOCK`` floats from
    ``start + i * stride`` for every listed ``i``, and ``acc`` ``BLOCK`` from ``first``, as
    :func:`_dense` does for each full block of a layer's outputs. The loads need no alignment
    (only speed does).
    """
    for name, array, dtype in (
        ("weights", weights, types.float64),
        ("x", x, types.float64),
        ("nonzero", nonzero, types.int64),
        ("acc", acc, types.float64),
    ):
        if not (isinstance(array, types.Array) and array.layout == "C" and array.dtype == dtype):
            raise TypingError(f"{name} must be a C-contiguous {dtype} array, not {array}")
    integer = types.int64
    signature = types.void(weights, integer, integer, x, nonzero, integer, acc, integer)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        def data(k: int) -> ir.Value:
            return context.make_array(sig.args[k])(context, builder, args[k]).data

        weights_at, x_at, nonzero_at, acc_at = data(0), data(3), data(4), data(6)
        start, stride, count, first = args[1], args[2], args[5], args[7]
        i32, i64 = ir.IntType(32), ir.IntType(64)
        vector = ir.VectorType(ir.DoubleType(), _LANES)
        sums = [
            cgutils.alloca_once_value(builder, ir.Constant(vector, [0.0] * _LANES))
            for _ in range(_VECTORS)
        ]
        with cgutils.for_range(builder, count) as loop:
            i = builder.load(builder.gep(nonzero_at, [loop.index]))
            xi = builder.load(builder.gep(x_at, [i]))
            spread = builder.insert_element(ir.Constant(vector, None), xi, ir.Constant(i32, 0))
            lane_zero = ir.Constant(ir.VectorType(i32, _LANES), [0] * _LANES)
            spread = builder.shuffle_vector(spread, ir.Constant(vector, None), lane_zero)
            row = builder.add(start, builder.mul(i, stride))
            for v, total in enumerate(sums):
                at = builder.gep(weights_at, [builder.add(row, ir.Constant(i64, v * _LANES))])
                w = builder.load(builder.bitcast(at, vector.as_pointer()), align=8)
                builder.store(builder.fadd(builder.load(total), builder.fmul(spread, w)), total)
        for v, total in enumerate(sums):
            at = builder.gep(acc_at, [builder.add(first, ir.Constant(i64, v * _LANES))])
            builder.store(builder.load(total), builder.bitcast(at, vector.as_pointer()), align=8)
        return context.get_dummy_value()

    return signature, codegen


@numba.njit(cache=True, inline="always")
def _list_nonzero(x, inputs, nonzero):  # type: ignore[no-untyped-def]  # pragma: no cover
    """How many of ``x[:inputs]`` are not 0; their indices first in ``nonzero``, branch-free."""
    count = 0
    for i in range(inputs):
        nonzero[count] = i
        count += x[i] != 0.0
    return count


@numba.njit(cache=True, inline="always")
def _four_columns(weights, x, nonzero, count, b0, s0, b1, s1, b2, s2, b3, s3):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """Four sums ``Σ_k x[i_k] · weights[b + i_k · s]`` at once, each in a register.

    ``i_k = nonzero[k]`` for ``k < count``; each sum starts at +0.0 and adds its products in
    ``k``'s order, as :func:`_dense`'s loop does. Four chains of additions side by side: one
    alone waits on each addition before the next.
    """
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    t3 = 0.0
    for k in range(count):
        i = nonzero[k]
        xi = x[i]
        t0 += xi * weights[b0 + i * s0]
        t1 += xi * weights[b1 + i * s1]
        t2 += xi * weights[b2 + i * s2]
        t3 += xi * weights[b3 + i * s3]
    return t0, t1, t2, t3


@numba.njit(cache=True, inline="always")
def _dense(weights, row, x, out, relu, acc, nonzero):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``out = x @ W + b`` (ReLU'd if ``relu``) for the layer ``row = (W at, in, out, b at)``.

    ``W`` is stored ``[in, out]`` row-major. Each output sums its products in input order from
    +0.0, one accumulator each (no reassociation, so the result is the same however the outputs
    are grouped or vectorised). An input of 0 (a unit the ReLU switched off: about half of a
    trunk's) is left out: its products are ±0 for finite weights, and adding ±0 to an
    accumulator that starts at +0 never changes it, so every sum is the full loop's, bit for
    bit. The inputs that are not 0 are listed first, without a branch (``nonzero``), since a
    branch on each input mispredicts often. The outputs go ``BLOCK`` at a time through
    :func:`_block_sums`, the rest (a head's one or two) four at a time through
    :func:`_four_columns`, each sum in a register (the policy head took 0.19 µs summing into
    ``acc`` in a loop over its outputs, 0.16 one output at a time in a register; four at a time
    and both heads in one pass, see :func:`network_into`, less again).

    ``acc`` (the accumulators) and ``nonzero`` are scratch at least as long as the layer's
    outputs and inputs, not fresh arrays (an allocation per layer cost about a tenth of a
    forward pass). Inlined, as :func:`_mlp` is, into the search kernel: a call per layer cost
    the PUCT decision about a tenth too.
    """
    at = row[0]
    inputs = row[1]
    outputs = row[2]
    bias = row[3]
    count = _list_nonzero(x, inputs, nonzero)
    blocked = outputs - outputs % BLOCK
    for first in range(0, blocked, BLOCK):
        _block_sums(weights, at + first, outputs, x, nonzero, count, acc, first)
    last = at + outputs - 1  # columns past the layer's last repeat it (their sums unused)
    for j in range(blocked, outputs, 4):
        sums = _four_columns(
            weights,
            x,
            nonzero,
            count,
            at + j,
            outputs,
            min(at + j + 1, last),
            outputs,
            min(at + j + 2, last),
            outputs,
            min(at + j + 3, last),
            outputs,
        )
        for c in range(min(4, outputs - j)):
            acc[j + c] = sums[c]
    for j in range(outputs):
        value = acc[j] + weights[bias + j]
        out[j] = value if (value > 0.0 or not relu) else 0.0


@numba.njit(cache=True, inline="always")
def _mlp(weights, layout, first, count, x, scratch, nonzero, relu_last):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """Layers ``first .. first + count - 1`` on ``x``, ReLU between; returns the output buffer.

    The layers write to ``scratch[1]`` and ``scratch[2]`` in turn; ``scratch[3]`` accumulates.
    """
    source = x
    for k in range(count):
        target = scratch[1 + k % 2]
        _dense(
            weights,
            layout[first + k],
            source,
            target,
            relu_last or k < count - 1,
            scratch[3],
            nonzero,
        )
        source = target
    return source


@numba.njit(cache=True)
def network_scratch(layout, dim):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``(scratch, nonzero)`` for :func:`network_into`: ``[4, width]`` floats and ``[width]`` ints.

    ``width`` is the widest layer, or ``dim`` (the input's length) if that is wider.
    """
    width = dim
    for k in range(layout.shape[0]):
        width = max(width, layout[k, 1], layout[k, 2])
    return np.empty((4, width)), np.empty(width, dtype=np.int64)


@numba.njit(cache=True, inline="always")
def _head_column(c, policy_at, num_actions, value_at):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``(first weight, stride)`` of column ``c`` of both one-layer heads side by side.

    The policy's ``num_actions`` outputs come first, then the value's one, which also fills
    the columns after it (their sums unused).
    """
    if c < num_actions:
        return policy_at + c, num_actions
    return value_at, 1


@numba.njit(cache=True, inline="always")
def _softmax_into(logits, priors):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``priors = softmax(logits[:len(priors)])``, the largest logit subtracted first."""
    num_actions = priors.shape[0]
    top = logits[0]
    for a in range(1, num_actions):
        top = max(top, logits[a])
    total = 0.0
    for a in range(num_actions):
        priors[a] = math.exp(logits[a] - top)
        total += priors[a]
    for a in range(num_actions):
        priors[a] = priors[a] / total


@numba.njit(cache=True)
def network_into(weights, layout, parts, x, priors, scratch, nonzero):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``PolicyValueFunction`` on features ``x``: writes the softmax priors, returns the value.

    ``weights``/``layout``/``parts`` are :meth:`PolicyValueFunction.packed`; ``scratch`` and
    ``nonzero`` come from :func:`network_scratch`. Where both heads are one layer and there
    are at most three actions (CartPole's network), the heads are one pass over the trunk's
    non-zero outputs, their sums side by side (:func:`_four_columns`): the sums each head's
    :func:`_dense` makes, in one pass instead of two (CartPole's forward pass 1.04 against
    1.14 µs).
    """
    trunk = parts[0]
    policy = parts[1]
    h = _mlp(weights, layout, 0, trunk, x, scratch, nonzero, True)
    outputs = layout[trunk, 2]  # the policy's, which priors has as many of
    if policy == 1 and parts[2] == 1 and outputs < 4:
        policy_at = layout[trunk, 0]
        value_at = layout[trunk + 1, 0]
        count = _list_nonzero(h, layout[trunk, 1], nonzero)
        b0, s0 = _head_column(0, policy_at, outputs, value_at)
        b1, s1 = _head_column(1, policy_at, outputs, value_at)
        b2, s2 = _head_column(2, policy_at, outputs, value_at)
        b3, s3 = _head_column(3, policy_at, outputs, value_at)
        sums = _four_columns(weights, h, nonzero, count, b0, s0, b1, s1, b2, s2, b3, s3)
        logits = scratch[0]  # h is scratch[1] or [2]
        for a in range(outputs):
            logits[a] = sums[a] + weights[layout[trunk, 3] + a]
        _softmax_into(logits, priors)
        return sums[outputs] + weights[layout[trunk + 1, 3]]
    kept = scratch[0]  # the heads' layers write to scratch[1] and [2]
    for j in range(layout[trunk - 1, 2]):
        kept[j] = h[j]
    _softmax_into(_mlp(weights, layout, trunk, policy, kept, scratch, nonzero, False), priors)
    return _mlp(weights, layout, trunk + policy, parts[2], kept, scratch, nonzero, False)[0]


@numba.njit(cache=True)
def network(weights, layout, parts, x):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``(priors, value)`` of features ``x`` (float64): :func:`network_into` with fresh buffers."""
    priors = np.empty(layout[parts[0] + parts[1] - 1, 2])
    scratch, nonzero = network_scratch(layout, x.shape[0])
    x = np.ascontiguousarray(x)  # the dense layers' vector code reads it as C-contiguous
    value = network_into(weights, layout, parts, x, priors, scratch, nonzero)
    return priors, value


# --- the last search's evaluations, found again by their network input --------------------------
#: An odd 64-bit multiplier (2^64 / golden ratio, as a signed int64) that spreads the hash's bits.
_SPREAD = -7046029254386353131


@numba.njit(cache=True)
def _input_hash(bits, mask):  # type: ignore[no-untyped-def]  # pragma: no cover
    """A slot in ``[0, mask]`` for one network input, given as its float64s' bit patterns."""
    h = 0
    for j in range(bits.shape[0]):
        h = (h ^ bits[j]) * _SPREAD  # int64 arithmetic wraps around
    return (h ^ (h >> 32)) & mask


@numba.njit(cache=True)
def _same_bits(a, b):  # type: ignore[no-untyped-def]  # pragma: no cover
    for j in range(a.shape[0]):
        if a[j] != b[j]:
            return False
    return True


@numba.njit(cache=True)
def _memo_slots(key_bits):  # type: ignore[no-untyped-def]  # pragma: no cover
    """An open-addressing index of the rows of ``key_bits`` (``[count, dim]`` int64 bits).

    A power-of-two table at most half full, -1 where empty; a row equal to an earlier one is
    left out (the earlier one is found).
    """
    size = 16
    while size < 2 * key_bits.shape[0]:
        size *= 2
    slots = np.full(size, -1, dtype=np.int64)
    mask = size - 1
    for i in range(key_bits.shape[0]):
        slot = _input_hash(key_bits[i], mask)
        while slots[slot] >= 0 and not _same_bits(key_bits[slots[slot]], key_bits[i]):
            slot = (slot + 1) & mask
        if slots[slot] < 0:
            slots[slot] = i
    return slots


@numba.njit(cache=True, inline="always")
def _memo_find(slots, key_bits, bits):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The row of ``key_bits`` equal to ``bits`` bit for bit, or -1."""
    mask = slots.shape[0] - 1
    slot = _input_hash(bits, mask)
    while slots[slot] >= 0:
        if _same_bits(key_bits[slots[slot]], bits):
            return slots[slot]
        slot = (slot + 1) & mask
    return -1


@numba.njit(cache=True)
def puct_vector(  # type: ignore[no-untyped-def]  # pragma: no cover
    data,
    root,
    root_priors,
    root_value,
    weights,
    layout,
    parts,
    memo_inputs,
    memo_priors,
    memo_values,
    iterations,
    depth,
    c,
    gamma,
    normalise,
    model_rng,
    search_rng,
):
    """PUCT over a family's compiled step, the network evaluated on each new node's state.

    ``root`` is the root's ``float64`` state vector; a node's network input is its state vector
    rounded to float32 (the family's observation) and back. Children of a chance node are keyed
    by the exact next state vector; a deterministic family's known edge is walked without
    simulating it again (see :func:`~ns_pz.agents.search._kernels.uct`).

    ``memo_inputs`` ``[count, dim]``, ``memo_priors`` ``[count, num_actions]`` and
    ``memo_values`` ``[count]`` are earlier evaluations of *this* network (the memo a previous
    call returned; ``count`` may be 0): a new node whose network input equals one of
    ``memo_inputs`` bit for bit takes its priors and value rather than evaluating the network
    again, which would compute the same bits (the forward pass is a function of its input).

    Returns ``(root visits, root Q, nodes, simulated steps, inputs, priors, values, found)``:
    ``inputs``/``priors``/``values`` are this tree's evaluated nodes (every non-terminal one but
    the root, whose priors may carry noise), the memo for the next call; ``found`` counts the
    nodes taken from the memo.
    """
    num_actions = root_priors.shape[0]
    dim = root.shape[0]
    capacity = iterations + 1
    states = np.empty((capacity, dim))
    terminal = np.zeros(capacity, dtype=np.bool_)
    value = np.zeros(capacity)
    priors = np.zeros((capacity, num_actions))
    n = np.zeros(capacity, dtype=np.int64)
    visits = np.zeros((capacity, num_actions), dtype=np.int64)
    w = np.zeros((capacity, num_actions))
    q = np.zeros((capacity, num_actions))
    first_child = np.full((capacity, num_actions), -1, dtype=np.int64)
    next_sibling = np.full(capacity, -1, dtype=np.int64)
    longest = min(depth, capacity) + 2
    path_nodes = np.empty(longest, dtype=np.int64)
    path_actions = np.empty(longest, dtype=np.int64)
    path_rewards = np.empty(longest)
    scores = np.empty(num_actions)
    ties = np.empty(num_actions, dtype=np.int64)
    current = np.empty(dim)
    sampled = np.empty(dim)
    new_priors = np.empty(num_actions)
    edge_reward = np.zeros((capacity, num_actions))  # read only for a deterministic family
    deterministic = family_is_deterministic(data)
    x = np.empty(dim)
    scratch, nonzero = network_scratch(layout, dim)
    inputs = np.empty((capacity, dim))  # each node's network input
    input_bits = inputs.view(np.int64)
    x_bits = x.view(np.int64)
    memo_bits = memo_inputs.view(np.int64)
    memo_slots = _memo_slots(memo_bits)
    found = 0
    states[0] = root
    value[0] = root_value
    priors[0] = root_priors
    q[0, :] = root_value
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
            sqrt_n = math.sqrt(1 + n[node])  # puct._select, written out (module docstring)
            best = -np.inf
            for a in range(num_actions):
                scaled = q[node, a]
                if normalise and hi > lo:
                    scaled = (scaled - lo) / (hi - lo)
                scores[a] = scaled + c * priors[node, a] * sqrt_n / (1 + visits[node, a])
                if scores[a] > best:
                    best = scores[a]
            count = 0
            for a in range(num_actions):
                if scores[a] == best:
                    ties[count] = a
                    count += 1
            action = ties[0] if count == 1 else ties[_uniform_index(search_rng, count)]
            known = deterministic and first_child[node, action] >= 0
            if known:  # the edge's one outcome, as simulated when it was added
                child = first_child[node, action]
                last = -1
                reward = edge_reward[node, action]
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
            if child < 0:
                child = num_nodes
                num_nodes += 1
                states[child] = sampled
                edge_reward[node, action] = reward
                if last < 0:
                    first_child[node, action] = child
                else:
                    next_sibling[last] = child
                if done:
                    terminal[child] = True
                else:
                    for j in range(dim):
                        x[j] = np.float64(np.float32(sampled[j]))
                        input_bits[child, j] = x_bits[j]
                    remembered = _memo_find(memo_slots, memo_bits, x_bits)
                    if remembered >= 0:
                        for a in range(num_actions):
                            new_priors[a] = memo_priors[remembered, a]
                        value[child] = memo_values[remembered]
                        found += 1
                    else:
                        value[child] = network_into(
                            weights, layout, parts, x, new_priors, scratch, nonzero
                        )
                    for a in range(num_actions):
                        priors[child, a] = new_priors[a]
                        q[child, a] = value[child]
                leaf = value[child]
                break
            node = child
            if terminal[node] or level == depth:
                leaf = value[node]
                break
            level += 1
        lo, hi = _backup(
            path_nodes, path_actions, path_rewards, length, leaf, gamma, n, visits, w, q, lo, hi
        )
    evaluated = np.flatnonzero(~terminal[1:num_nodes]) + 1
    return (
        visits[0].copy(),
        q[0].copy(),
        num_nodes,
        simulated,
        inputs[evaluated],
        priors[evaluated],
        value[evaluated],
        found,
    )
