"""Compiled (numba) parts of a float64 Double-DQN step; imported on first use.

The elementwise arithmetic: the Double-DQN target and the loss's gradient at the output
(:func:`td_delta`), and Adam with the Polyak update of the target and the subnormal flush
(:func:`adam_polyak`). Each element goes through the same IEEE operations, in the same order, as
in :class:`~ns_pz.agents.learning.mlp.MLPLearner` and
:class:`~ns_pz.agents.learning.ddqn.DoubleDQN`'s NumPy code (numba contracts no multiply-add
into a fused one unless asked for ``fastmath``), so a learner trains the same bits with or
without numba.

The matrix products: a loop would sum them in another order than BLAS, so they are NumPy's own
BLAS routines (:mod:`~ns_pz.agents.learning.numpy_blas`), called with the arguments
numpy.matmul passes for the same operands. With them, a whole gradient step (:func:`ddqn_step`)
and a greedy action (:func:`greedy_action`) are one compiled call each, NumPy's bits, without
NumPy's cost per call (about thirty calls of a microsecond each per gradient step).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from ns_pz.agents.search import numba_cache
from ns_pz.agents.search._kernels import family_step
from numba.core import types
from numba.core.errors import TypingError
from numba.extending import intrinsic

numba_cache.install()  # before the first cache=True below: caches go to a user folder

#: The smallest normal float64; below it a value is subnormal (``np.finfo(float).tiny``).
TINY = float(np.finfo(np.float64).tiny)


@numba.njit(cache=True, boundscheck=True)  # an action out of range: IndexError, as in NumPy
def td_delta(q, next_online, next_target, actions, rewards, terminated, gamma, delta, squares):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """The loss's gradient at the output into ``delta``, the squared TD errors into ``squares``.

    As ``DoubleDQN.loss_and_gradient``: ``y = r + (γ (1 - done)) Q_target(s', a*)`` with ``a*``
    the online network's first best action (a NaN counts as the best, as ``argmax``'s),
    ``error = Q(s, a) - y``, ``delta[r, a] = 2 error / batch`` and 0 elsewhere, subnormal
    entries flushed.
    """
    rows, num_actions = q.shape
    for r in range(rows):
        best = _first_best(next_online[r])
        y = rewards[r] + gamma * (1.0 - terminated[r]) * next_target[r, best]
        e = q[r, actions[r]] - y
        squares[r] = e * e
        for a in range(num_actions):
            delta[r, a] = 0.0
        d = 2.0 * e / rows
        delta[r, actions[r]] = 0.0 if abs(d) < TINY else d


@numba.njit(cache=True)
def adam_polyak(  # type: ignore[no-untyped-def]  # pragma: no cover
    params,
    grad,
    m,
    v,
    target,
    learning_rate,
    weight_decay,
    beta1,
    beta2,
    eps,
    correction1,
    root_correction2,
    tau,
):
    """One Adam step of ``params`` along ``grad``, then ``target`` moves towards ``params``.

    As ``MLPLearner.adam_step`` then ``DoubleDQN.gradient_step``'s Polyak update: weight decay
    added to the gradient (in ``grad``, as there), the moments, the bias-corrected step (the
    corrections computed by the caller in Python, ``root_correction2`` the square root of the
    second), the subnormal flush of ``params``, ``m`` and ``v``, then ``target <- (1 - τ) target
    + τ params`` and its flush.
    """
    step_size = learning_rate / correction1
    for k in range(params.shape[0]):
        g = grad[k]
        if weight_decay:
            g = g + weight_decay * params[k]
            grad[k] = g
        mk = m[k] * beta1 + (1.0 - beta1) * g
        vk = v[k] * beta2 + (1.0 - beta2) * g * g
        p = params[k] - step_size * mk / (math.sqrt(vk) / root_correction2 + eps)
        m[k] = 0.0 if abs(mk) < TINY else mk
        v[k] = 0.0 if abs(vk) < TINY else vk
        p = 0.0 if abs(p) < TINY else p
        params[k] = p
        t = target[k] * (1.0 - tau) + tau * p
        target[k] = 0.0 if abs(t) < TINY else t


# --- whole steps, the products through NumPy's own BLAS -------------------------------------------
# ``blas`` is :func:`ns_pz.agents.learning.numpy_blas.blas_routines`: the addresses of the
# ``cblas_dgemm`` and ``cblas_dgemv`` numpy.matmul calls. Each product below is the call
# numpy.matmul makes for the same operands (row-major; a single row times a matrix through dgemv),
# so the results are NumPy's bits; the learner checks that once per shape before relying on it.

_ROW_MAJOR = 101
_NO_TRANS = 111
_TRANS = 112


def _array_pointer(context, builder, array_type, array):  # type: ignore[no-untyped-def]  # pragma: no cover  # noqa: E501
    data = context.make_array(array_type)(context, builder, array).data
    return builder.bitcast(data, ir.IntType(8).as_pointer())


def _require_c_float64(*arrays):  # type: ignore[no-untyped-def]
    """Refuse, at compile time, an operand BLAS would misread: not C-contiguous float64."""
    for array in arrays:
        if not (isinstance(array, types.Array) and array.layout == "C"):
            raise TypingError(f"BLAS operands must be C-contiguous arrays, not {array}")
        if array.dtype != types.float64:
            raise TypingError(f"BLAS operands must be float64, not {array.dtype}")


@intrinsic
def _dgemm(typingctx, address, trans_a, trans_b, m, n, k, a, lda, b, ldb, c, ldc):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """``c = op(a) op(b)`` (row-major; alpha 1, beta 0) by the ILP64 cblas_dgemm at ``address``."""
    _require_c_float64(a, b, c)
    signature = types.void(address, trans_a, trans_b, m, n, k, a, lda, b, ldb, c, ldc)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        i32, i64, f64 = ir.IntType(32), ir.IntType(64), ir.DoubleType()
        pointer = ir.IntType(8).as_pointer()
        function_type = ir.FunctionType(
            ir.VoidType(),
            [i32, i32, i32, i64, i64, i64, f64, pointer, i64, pointer, i64, f64, pointer, i64],
        )
        function = builder.inttoptr(args[0], function_type.as_pointer())
        arguments = [
            ir.Constant(i32, _ROW_MAJOR),
            builder.trunc(args[1], i32),
            builder.trunc(args[2], i32),
            args[3],
            args[4],
            args[5],
            ir.Constant(f64, 1.0),
            _array_pointer(context, builder, sig.args[6], args[6]),
            args[7],
            _array_pointer(context, builder, sig.args[8], args[8]),
            args[9],
            ir.Constant(f64, 0.0),
            _array_pointer(context, builder, sig.args[10], args[10]),
            args[11],
        ]
        builder.call(function, arguments)
        return context.get_dummy_value()

    return signature, codegen


@intrinsic
def _dgemv_row(typingctx, address, k, n, a, x, y):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``y = x @ a`` for ``a`` ``[k, n]`` row-major: numpy.matmul's dgemv for a row times it."""
    _require_c_float64(a, x, y)
    signature = types.void(address, k, n, a, x, y)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        i32, i64, f64 = ir.IntType(32), ir.IntType(64), ir.DoubleType()
        pointer = ir.IntType(8).as_pointer()
        function_type = ir.FunctionType(
            ir.VoidType(), [i32, i32, i64, i64, f64, pointer, i64, pointer, i64, f64, pointer, i64]
        )
        function = builder.inttoptr(args[0], function_type.as_pointer())
        one = ir.Constant(i64, 1)
        arguments = [
            ir.Constant(i32, _ROW_MAJOR),
            ir.Constant(i32, _TRANS),
            args[1],
            args[2],
            ir.Constant(f64, 1.0),
            _array_pointer(context, builder, sig.args[3], args[3]),
            args[2],
            _array_pointer(context, builder, sig.args[4], args[4]),
            one,
            ir.Constant(f64, 0.0),
            _array_pointer(context, builder, sig.args[5], args[5]),
            one,
        ]
        builder.call(function, arguments)
        return context.get_dummy_value()

    return signature, codegen


@numba.njit(cache=True, inline="always")
def _matmul(blas, a, b, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``out = a @ b`` for C-contiguous ``a`` ``[m, k]`` and ``b`` ``[k, n]``, as numpy.matmul."""
    m, k = a.shape
    n = b.shape[1]
    if b.shape[0] != k or out.shape[0] != m or out.shape[1] != n:
        raise ValueError("matmul: the operands' shapes do not chain")
    if m == 1:
        _dgemv_row(blas[1], k, n, b, a, out)
    else:
        _dgemm(blas[0], _NO_TRANS, _NO_TRANS, m, n, k, a, k, b, n, out, n)


@numba.njit(cache=True, inline="always")
def _matmul_at(blas, a, b, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``out = a.T @ b`` for C-contiguous ``a`` ``[k, m]`` and ``b`` ``[k, n]`` (``k`` >= 2)."""
    k, m = a.shape
    n = b.shape[1]
    if b.shape[0] != k or out.shape[0] != m or out.shape[1] != n:
        raise ValueError("matmul: the operands' shapes do not chain")
    _dgemm(blas[0], _TRANS, _NO_TRANS, m, n, k, a, m, b, n, out, n)


@numba.njit(cache=True, inline="always")
def _matmul_bt(blas, a, b, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``out = a @ b.T`` for C-contiguous ``a`` ``[m, k]`` (``m`` >= 2) and ``b`` ``[n, k]``."""
    m, k = a.shape
    n = b.shape[0]
    if b.shape[1] != k or out.shape[0] != m or out.shape[1] != n:
        raise ValueError("matmul: the operands' shapes do not chain")
    _dgemm(blas[0], _NO_TRANS, _TRANS, m, n, k, a, k, b, k, out, n)


@numba.njit(cache=True)
def _layer(params, layout, i):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Layer ``i``'s ``(W [in, out], b [out])``, views of the flat ``params``."""
    at, inputs, outputs, bias = layout[i, 0], layout[i, 1], layout[i, 2], layout[i, 3]
    w = params[at : at + inputs * outputs].reshape((inputs, outputs))
    return w, params[bias : bias + outputs]


@numba.njit(cache=True)
def _affine(blas, w, b, h, z, relu):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``z = h @ w + b``, then ``np.maximum(z, 0.0)`` if ``relu``: ``mlp.forward``'s arithmetic."""
    _matmul(blas, h, w, z)
    rows, outputs = z.shape
    for r in range(rows):
        for j in range(outputs):
            value = z[r, j] + b[j]
            if relu and not (value > 0.0 or math.isnan(value)):
                value = 0.0  # np.maximum(value, 0.0): NaN stays, -0.0 becomes +0.0
            z[r, j] = value


@numba.njit(cache=True)
def forward_rows(blas, layout, params, x):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The MLP's outputs on rows ``x`` (``[rows, inputs]`` C-contiguous float64): NumPy's bits."""
    h = x
    last = layout.shape[0] - 1
    for i in range(layout.shape[0]):
        w, b = _layer(params, layout, i)
        z = np.empty((h.shape[0], w.shape[1]))
        _affine(blas, w, b, h, z, i < last)
        h = z
    return h


@numba.njit(cache=True)
def greedy_action(blas, layout, params, x):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``argmax`` of the MLP's outputs on one feature vector ``x`` (NaN first, then first best)."""
    h = np.empty((1, x.shape[0]))
    for j in range(x.shape[0]):
        h[0, j] = x[j]
    return _first_best(forward_rows(blas, layout, params, h)[0])


@numba.njit(cache=True)
def greedy_rows(blas, layout, params, x):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Each row's :func:`greedy_action` for feature rows ``x`` (``[rows, inputs]``, any layout)."""
    h = np.empty(x.shape)  # C-contiguous float64, whatever x is
    for r in range(x.shape[0]):
        for j in range(x.shape[1]):
            h[r, j] = x[r, j]
    q = forward_rows(blas, layout, params, h)
    actions = np.empty(q.shape[0], dtype=np.int64)
    for r in range(q.shape[0]):
        actions[r] = _first_best(q[r])
    return actions


@numba.njit(cache=True)
def _first_best(values):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``np.argmax(values)``: the first NaN, else the first of the largest."""
    best = 0
    top = values[0]
    if math.isnan(top):
        return 0
    for a in range(1, values.shape[0]):
        value = values[a]
        if math.isnan(value):
            return a
        if value > top:
            best, top = a, value
    return best


@numba.njit(cache=True, boundscheck=True)  # an index out of the buffer: IndexError, as in NumPy
def ddqn_step(  # type: ignore[no-untyped-def]  # pragma: no cover
    blas,
    layout,
    params,
    grad,
    m,
    v,
    target,
    index,
    features,
    actions,
    rewards,
    next_features,
    terminated,
    gamma,
    learning_rate,
    weight_decay,
    beta1,
    beta2,
    eps,
    correction1,
    root_correction2,
    tau,
):
    """One Double-DQN gradient step on the buffer rows ``index``; returns the squared TD errors.

    As ``DoubleDQN.gradient_step`` on ``ReplayBuffer.batch(index)``, every product the call
    numpy.matmul makes: the next states' values by the online and the target network, the
    online forward pass, :func:`td_delta`, the backward pass (``grad_i = h_i.T @ delta``, the
    bias gradient as ``delta.sum(axis=0)`` adds its rows from 0, ``delta <- (delta @ W_i.T) *
    (h_i > 0)``), then :func:`adam_polyak`.
    """
    rows = index.shape[0]
    num_layers = layout.shape[0]
    inputs = layout[0, 1]
    x = np.empty((rows, inputs))
    next_x = np.empty((rows, inputs))
    batch_actions = np.empty(rows, dtype=actions.dtype)
    batch_rewards = np.empty(rows, dtype=rewards.dtype)
    batch_terminated = np.empty(rows, dtype=terminated.dtype)
    for r in range(rows):
        i = index[r]
        for j in range(inputs):
            x[r, j] = features[i, j]
            next_x[r, j] = next_features[i, j]
        batch_actions[r] = actions[i]
        batch_rewards[r] = rewards[i]
        batch_terminated[r] = terminated[i]
    next_online = forward_rows(blas, layout, params, next_x)
    next_target = forward_rows(blas, layout, target, next_x)
    hidden = [x]
    for i in range(num_layers):
        w, b = _layer(params, layout, i)
        z = np.empty((rows, w.shape[1]))
        _affine(blas, w, b, hidden[i], z, i < num_layers - 1)
        hidden.append(z)
    delta = np.empty_like(hidden[num_layers])
    squares = np.empty(rows)
    td_delta(
        hidden[num_layers],
        next_online,
        next_target,
        batch_actions,
        batch_rewards,
        batch_terminated,
        gamma,
        delta,
        squares,
    )
    for i in range(num_layers - 1, -1, -1):
        w, _ = _layer(params, layout, i)
        gw, gb = _layer(grad, layout, i)
        h = hidden[i]
        fan_in, fan_out = w.shape
        _matmul_at(blas, h, delta, gw)
        for j in range(fan_out):
            gb[j] = 0.0
        for r in range(rows):
            for j in range(fan_out):
                gb[j] += delta[r, j]
        if i:
            back = np.empty((rows, fan_in))
            _matmul_bt(blas, delta, w, back)
            for r in range(rows):
                for j in range(fan_in):
                    back[r, j] *= 1.0 if h[r, j] > 0.0 else 0.0
            delta = back
    adam_polyak(
        params,
        grad,
        m,
        v,
        target,
        learning_rate,
        weight_decay,
        beta1,
        beta2,
        eps,
        correction1,
        root_correction2,
        tau,
    )
    return squares


@numba.njit(cache=True)
def greedy_episode(data, start, blas, layout, params, rows, max_steps, rng):  # type: ignore[no-untyped-def]  # noqa: E501  # pragma: no cover
    """A greedy episode of the MLP from ``start`` in a family's compiled step: ``(return, steps)``.

    As ``FineTunedDDQNAgent._greedy_returns`` plays one episode of a family whose step draws
    nothing and whose observation is its state vector rounded to float32 (CartPole): each step
    the network sees the observation ``rows`` times (the scoring's batch of copies, whose
    product rounds as that batch's does), takes row 0's first best action and steps
    ``family_step`` under ``data``'s θ, for at most ``max_steps`` steps or to a terminal state.
    """
    dim = start.shape[0]
    state = start.copy()
    following = np.empty(dim)
    x = np.empty((rows, dim))
    total = 0.0
    steps = 0
    for _ in range(max_steps):
        for r in range(rows):
            for j in range(dim):
                x[r, j] = np.float64(np.float32(state[j]))
        action = _first_best(forward_rows(blas, layout, params, x)[0])
        reward, done = family_step(data, state, following, action, rng)
        total += reward
        steps += 1
        state, following = following, state
        if done:
            break
    return total, steps


@numba.njit(cache=True)
def replay_steps(  # type: ignore[no-untyped-def]  # pragma: no cover
    blas,
    layout,
    params,
    grad,
    m,
    v,
    target,
    size,
    batch_size,
    features,
    actions,
    rewards,
    next_features,
    terminated,
    gamma,
    learning_rate,
    weight_decay,
    beta1,
    beta2,
    eps,
    corrections1,
    root_corrections2,
    tau,
    rng,
    done,
):
    """One :func:`ddqn_step` per entry of ``corrections1``, each on a fresh sample of rows.

    As ``DoubleDQN.replay_step`` that many times: each step draws ``rng.integers(0, size,
    batch_size)`` (``ReplayBuffer.sample_index``'s draw, the same numbers) and runs the step
    with that step's Adam corrections. ``done[0]`` counts the steps made, kept up to date in
    case one raises.
    """
    for s in range(corrections1.shape[0]):
        index = rng.integers(0, size, batch_size)
        ddqn_step(
            blas, layout, params, grad, m, v, target, index, features, actions, rewards,
            next_features, terminated, gamma, learning_rate, weight_decay, beta1, beta2, eps,
            corrections1[s], root_corrections2[s], tau,
        )  # fmt: skip
        done[0] += 1


@numba.njit(cache=True)
def collect_transitions(  # type: ignore[no-untyped-def]  # pragma: no cover
    data,
    state,
    start,
    count,
    epsilon,
    num_actions,
    blas,
    layout,
    params,
    features,
    actions,
    rewards,
    next_features,
    terminated,
    row,
    rng,
    model_rng,
):
    """``count`` ε-greedy transitions from ``state`` in a family's compiled step, into a buffer.

    As ``FineTunedDDQNAgent``'s transitions added to its ``ReplayBuffer`` one by one, for a
    family whose observation is its state vector rounded to float32 (CartPole): per transition
    ``rng.random() < epsilon`` picks ``rng.integers(0, num_actions)``, else the network's first
    best action on the observation (one row, as ``DoubleDQN.greedy``); ``family_step`` under
    ``data``'s θ draws from ``model_rng`` (the planning model's own generator, as its
    ``transition``); the transition goes to buffer row ``row`` and on, wrapping at the end; a
    terminal one starts the next from ``start``. ``state`` is left at the state to go on from;
    returns the row the next transition goes to.
    """
    dim = state.shape[0]
    capacity = features.shape[0]
    following = np.empty(dim)
    x = np.empty((1, dim))
    for _ in range(count):
        if rng.random() < epsilon:
            action = rng.integers(0, num_actions)
        else:
            for j in range(dim):
                x[0, j] = np.float64(np.float32(state[j]))
            action = _first_best(forward_rows(blas, layout, params, x)[0])
        reward, done = family_step(data, state, following, action, model_rng)
        for j in range(dim):
            features[row, j] = np.float32(state[j])
            next_features[row, j] = np.float32(following[j])
        actions[row] = action
        rewards[row] = np.float32(reward)
        terminated[row] = 1.0 if done else 0.0
        row = (row + 1) % capacity
        for j in range(dim):
            state[j] = start[j] if done else following[j]
    return row
