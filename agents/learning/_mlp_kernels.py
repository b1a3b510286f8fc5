"""Compiled (numba) elementwise parts of a float64 Double-DQN step; imported on first use.

Only arithmetic that is elementwise is compiled here: the Double-DQN target and the loss's
gradient at the output (:func:`td_delta`), and Adam with the Polyak update of the target and the
subnormal flush (:func:`adam_polyak`). Each element goes through the same IEEE operations, in
the same order, as in :class:`~ns_pz.agents.learning.mlp.MLPLearner` and
:class:`~ns_pz.agents.learning.ddqn.DoubleDQN`'s NumPy code (numba contracts no multiply-add
into a fused one unless asked for ``fastmath``), so a learner trains the same bits with or
without numba. The matrix products stay in NumPy: BLAS sums them in an order a loop would not
repeat. What this saves is NumPy's cost per call: about thirty calls of a microsecond each per
gradient step, on vectors of a few thousand entries.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from ns_pz.agents.search import numba_cache

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
        best = 0
        top = next_online[r, 0]
        if not math.isnan(top):
            for a in range(1, num_actions):
                value = next_online[r, a]
                if math.isnan(value):
                    best = a
                    break
                if value > top:
                    best, top = a, value
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
