"""Training a ReLU MLP in NumPy: flat parameters, a hand-written backward pass, Adam.

The learners' networks are MLPs of one to four layers of 64–128 units. In torch their cost per
call (autograd, module dispatch, the optimiser's per-tensor loop, and a first optimiser that
imports torch's compiler: about 3 s) dwarfs the arithmetic on one core, so Double DQN and
AlphaZero train them here. :class:`MLPLearner` keeps every weight and bias in one flat vector
(the layers are views of it), so Adam is a handful of vector operations, and its gradient is
the ReLU MLP's backward pass written out, given the loss's gradient with respect to the output.
Each learner owns its loss: it runs :meth:`MLPLearner.forward`, computes the output's gradient
and hands it to :meth:`MLPLearner.backward`. Tested against torch's autograd and
``torch.optim.Adam`` in float64.
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Iterator, Sequence

import numpy as np
from threadpoolctl import ThreadpoolController

ADAM_BETAS = (0.9, 0.999)
"""Adam's decay rates of the first and second moments (torch's defaults)."""
ADAM_EPS = 1e-8
"""Adam's ε, added to the root of the second moment (torch's default)."""

Layers = list[tuple[np.ndarray, np.ndarray]]
"""``(W [in, out], b [out])`` per layer, views into a flat parameter vector."""

_TINY = {np.dtype(t).char: np.finfo(t).tiny for t in (np.float32, np.float64)}
"""The smallest normal value of the learners' dtypes (``np.finfo`` costs a call each time)."""


@functools.cache
def _blas() -> ThreadpoolController:
    return ThreadpoolController()  # finds the loaded BLAS libraries once (milliseconds)


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with the BLAS numpy uses on one thread, whatever the process allows.

    The limit covers the BLAS libraries loaded at its first use, numpy's among them (imported
    with this module); one a later import brings in (torch's, scipy's) is left as it is.

    Training runs under it: a product split over several threads sums in another order, so
    the same seed would train other bits on another machine or outside a benchmark worker (the
    quick CliffWalking AlphaZero network scored 77.0 trained on two threads, 83.75 on one).
    """
    with _blas().limit(limits=1, user_api="blas"):
        yield


def parameter_count(widths: Sequence[int]) -> int:
    """Weights and biases of the MLP ``widths[0] -> ... -> widths[-1]``."""
    return sum(a * b + b for a, b in zip(widths[:-1], widths[1:], strict=True))


def layer_views(flat: np.ndarray, widths: Sequence[int]) -> Layers:
    """``(W [in, out], b [out])`` views of ``flat``, layer by layer (each matrix, then its bias)."""
    views, at = [], 0
    for a, b in zip(widths[:-1], widths[1:], strict=True):
        views.append((flat[at : at + a * b].reshape(a, b), flat[at + a * b : at + a * b + b]))
        at += a * b + b
    return views


def export_layers(layers: Layers, prefix: str) -> dict[str, np.ndarray]:
    """``layers`` as ``{prefix.i.weight, prefix.i.bias}`` copies in torch's ``Linear`` layout.

    ``weight`` is ``[out, in]``: what :class:`~ns_pz.agents.learning.features.NumpyMLP` reads.
    """
    out: dict[str, np.ndarray] = {}
    for i, (w, b) in enumerate(layers):
        out[f"{prefix}.{i}.weight"], out[f"{prefix}.{i}.bias"] = w.T.copy(), b.copy()
    return out


def forward(layers: Layers, x: np.ndarray) -> np.ndarray:
    """The output of the MLP ``layers`` on rows ``x`` (ReLU between layers, none after the last)."""
    h = x
    last = len(layers) - 1
    for i, (w, b) in enumerate(layers):
        h = h @ w
        h += b
        if i < last:
            np.maximum(h, 0.0, out=h)
    return h


def flush_subnormals(values: np.ndarray) -> None:
    """Set the subnormal entries of ``values`` to zero, in place (what a CPU's FTZ mode does).

    Weight decay drives the weights of inputs a batch never sets (the one-hot entries of
    states never acted in) and of dead units, and their Adam moments, geometrically towards
    zero, into the subnormal range (below 1.2e-38 in float32, 2.2e-308 in float64), where every
    multiplication is tens of times slower: the full FrozenLake AlphaZero network's forward pass
    went from 0.3 ms to 13 ms once 981 of its weights were subnormal, and a gradient step of the
    full FrozenLake Double DQN (376 subnormal weights by step 120k) from 454 to 338 µs with them
    flushed. Torch on a CPU does the same arithmetic without flushing and pays the same. A
    subnormal weight contributes nothing an activation can hold, and a subnormal second moment
    nothing beside Adam's ε: flushed, the full FrozenLake Double DQN trained the same bits in
    every normal weight (only 330 subnormal ones became 0).
    """
    tiny = _TINY.get(values.dtype.char)
    if tiny is None:
        tiny = np.finfo(values.dtype).tiny
    np.copyto(values, 0.0, where=np.abs(values) < tiny)


class MLPLearner:
    """A ReLU MLP and Adam's state, as flat vectors of one dtype.

    Layer ``i`` computes ``h @ W_i + b_i`` with ReLU between layers (``W_i`` is ``[in, out]``,
    the transpose of torch's ``Linear.weight``). Adam follows ``torch.optim.Adam`` with L2
    weight decay (added to the gradient) and bias correction. Subnormal parameters and moments
    are flushed to zero after every step (:func:`flush_subnormals`); a float32 learner also
    leaves units a batch never activates out of its backward pass (a narrower product may round
    differently, so a float64 learner keeps the plain one).

    Args:
        widths: ``inputs, hidden..., outputs``.
        params: The flat parameters (copied, converted to ``dtype``).
        learning_rate: Adam's step size.
        weight_decay: L2 coefficient added to the gradient.
        dtype: ``float64`` or ``float32`` (inputs are converted to it).

    Raises:
        ValueError: Fewer than two widths, a width below 1, ``params`` of the wrong length or a
            dtype other than float32/float64.
    """

    def __init__(
        self,
        widths: Sequence[int],
        params: np.ndarray,
        learning_rate: float,
        weight_decay: float,
        dtype: type = np.float64,
    ) -> None:
        widths = [int(w) for w in widths]
        if len(widths) < 2 or min(widths) < 1:
            raise ValueError(f"widths={widths!r} must list at least two widths, each >= 1")
        if np.dtype(dtype) not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise ValueError(f"dtype={dtype!r} is not allowed; allowed: float32, float64")
        self.widths = widths
        self.dtype = np.dtype(dtype)
        self.size = parameter_count(widths)
        params = np.asarray(params, dtype=self.dtype)
        if params.shape != (self.size,):
            raise ValueError(
                f"params has shape {params.shape}; widths {widths} need ({self.size},)"
            )
        self.learning_rate = float(learning_rate)
        self.weight_decay = float(weight_decay)
        self.params = params.copy()
        self.grad = np.zeros(self.size, dtype=self.dtype)
        self.layers = layer_views(self.params, widths)
        self.grad_layers = layer_views(self.grad, widths)
        self.reset_optimizer()

    @staticmethod
    def initial_params(widths: Sequence[int], rng: np.random.Generator) -> np.ndarray:
        """Fresh flat parameters as torch's ``nn.Linear`` default: uniform in ``±1/sqrt(fan_in)``.

        Drawn layer by layer, the matrix (row-major ``[in, out]``) then the bias, in float64.
        """
        parts = []
        for fan_in, fan_out in zip(widths[:-1], widths[1:], strict=True):
            bound = 1.0 / np.sqrt(fan_in)
            parts.append(rng.uniform(-bound, bound, fan_in * fan_out))
            parts.append(rng.uniform(-bound, bound, fan_out))
        return np.concatenate(parts)

    def reset_optimizer(self) -> None:
        """Zero Adam's moments and step count (a fresh ``torch.optim.Adam``)."""
        self.m = np.zeros(self.size, dtype=self.dtype)
        self.v = np.zeros(self.size, dtype=self.dtype)
        self.steps = 0

    def as_input(self, x: np.ndarray) -> np.ndarray:
        """``x`` in the learner's dtype (no copy if it already is)."""
        return np.asarray(x, dtype=self.dtype)

    def forward(self, x: np.ndarray) -> list[np.ndarray]:
        """Every layer's output on rows ``x``, for :meth:`backward`: ``[x, h_1, ..., output]``."""
        hidden = [self.as_input(x)]
        last = len(self.layers) - 1
        for i, (w, b) in enumerate(self.layers):
            z = hidden[-1] @ w
            z += b
            if i < last:
                np.maximum(z, 0.0, out=z)
            hidden.append(z)
        return hidden

    def backward(self, hidden: list[np.ndarray], delta: np.ndarray, flushed: bool = False) -> None:
        """The loss's gradient into :attr:`grad`, given ``delta``: its gradient at the output.

        Args:
            hidden: :meth:`forward`'s outputs for the batch.
            delta: ``[batch, outputs]`` ∂loss/∂output (the batch mean already taken); its
                subnormal entries are flushed first (a softmax's probability of an action far
                below the others underflows into the subnormal range).
            flushed: ``delta`` holds no subnormal entry already (the flush is skipped).
        """
        if not flushed:
            flush_subnormals(delta)
        for i in range(len(self.layers) - 1, -1, -1):
            w, _ = self.layers[i]
            gw, gb = self.grad_layers[i]
            np.matmul(hidden[i].T, delta, out=gw)
            delta.sum(axis=0, out=gb)
            if i:
                active = hidden[i] > 0.0  # where the ReLU passed its input (and its gradient)
                live = active.any(axis=0) if self.dtype == np.float32 else None
                if live is None or live.all():
                    delta = delta @ w.T
                else:
                    # float32: a unit no row of the batch activates passes no gradient back, so
                    # its outgoing weights stay out of the product: weight decay has usually
                    # driven them towards zero while the unit was dead, and their products with
                    # the gradient would be subnormal, tens of times slower than the rest (a
                    # narrower product may round differently, so float64 keeps the plain one)
                    back = np.zeros((len(delta), w.shape[0]), dtype=self.dtype)
                    back[:, live] = delta @ w[live].T
                    delta = back
                delta *= active

    def adam_step(self) -> None:
        """One Adam step along :attr:`grad` (weight decay added to it first)."""
        beta1, beta2 = ADAM_BETAS
        self.steps += 1
        g = self.grad
        if self.weight_decay:
            g += self.weight_decay * self.params
        self.m *= beta1
        self.m += (1.0 - beta1) * g
        self.v *= beta2
        self.v += (1.0 - beta2) * g * g
        correction1 = 1.0 - beta1**self.steps
        correction2 = 1.0 - beta2**self.steps
        # Python floats, so a float32 learner stays float32 (a numpy float64 scalar would not)
        denominator = np.sqrt(self.v) / math.sqrt(correction2) + ADAM_EPS
        self.params -= (self.learning_rate / correction1) * self.m / denominator
        for state in (self.params, self.m, self.v):
            flush_subnormals(state)
