"""Double DQN (van Hasselt et al. 2016) trained on the stationary base env θ_0, in NumPy.

The training loop reads top to bottom like cleanrl's ``dqn.py``; the one thing that makes it
*Double* DQN is :func:`double_dqn_target`: the online network chooses the next action, the
target network evaluates it (NS-Gym's ``DDQN`` uses the vanilla ``max_a' Q_target`` target, and
in practice no separate target network at all).

Departures from NS-Gym's loop, each for a reason: ε decays linearly over a fraction of the
training *steps* (cleanrl) rather than ×0.999 per episode, so a short quick-size run still ends
greedy; truncation at ``max_episode_steps`` is not treated as termination (the target
bootstraps through it). The loss is the MSE of the spec, optimised by Adam with weight decay.

**NumPy, not torch.** The networks are MLPs of one to three layers of 64–128 units trained on
batches of 64, where torch's cost per call (autograd, module dispatch, the optimiser's
per-tensor loop: about 1 ms per gradient step on one core) dwarfs the arithmetic.
:class:`DoubleDQN` is a float64 :class:`~ns_pz.agents.learning.mlp.MLPLearner` (one flat vector
of parameters, the ReLU MLP's backward pass written out, Adam) with a target network beside it,
so the Polyak update is two vector operations (tested against torch's autograd and ``Adam``).
The same learner fine-tunes DDQN-WN's network when notified, so neither needs torch. Initial
weights follow torch's ``nn.Linear`` default, uniform in ``±1/sqrt(fan_in)``, drawn from their
own stream of the training seed.

Where numba is installed, a gradient step's elementwise parts (the target and the output's
gradient, Adam, the Polyak update, the subnormal flushes) run as two compiled loops
(:mod:`._mlp_kernels`) instead of about thirty NumPy calls. Where NumPy's bundled OpenBLAS is
found too, the whole step and the greedy action are one compiled call each, their products
through NumPy's own BLAS routines with the arguments numpy.matmul passes (:func:`products_for`,
checked against NumPy on random data once per network shape and row count). The network is
the same bit for bit on every path (tested). The full FrozenLake network (200k steps) trained
in 3.0–3.3 s whole-step compiled, against 5.3–5.7 s with the elementwise parts alone, on one
core of the development machine.
"""

from __future__ import annotations

import functools
import importlib
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict
from types import ModuleType
from typing import Any

import numpy as np
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.features import NumpyMLP, feature_size, features
from ns_pz.agents.learning.mlp import (
    ADAM_BETAS,
    ADAM_EPS,
    MLPLearner,
    export_layers,
    flush_subnormals,
    forward,
    layer_views,
    one_blas_thread,
)
from ns_pz.agents.learning.numpy_blas import blas_routines
from ns_pz.agents.learning.replay import Batch, ReplayBuffer
from ns_pz.agents.learning.seeding import training_seeds
from ns_pz.agents.search.compiled import numba_available

from ns_pz.process import DECISION
from ns_pz.views import NSGymEnv


def dqn_target(
    next_q_target: np.ndarray, rewards: np.ndarray, terminated: np.ndarray, gamma: float
) -> np.ndarray:
    """The vanilla DQN target ``r + γ (1 - done) max_a' Q_target(s', a')`` (for comparison).

    Args:
        next_q_target: ``[batch, num_actions]`` target-network values of the next states.
        rewards: ``[batch]``.
        terminated: ``[batch]``, 1.0 where the transition ended the episode.
        gamma: Discount.
    """
    return rewards + gamma * (1.0 - terminated) * next_q_target.max(axis=1)


def double_dqn_target(
    next_q_online: np.ndarray,
    next_q_target: np.ndarray,
    rewards: np.ndarray,
    terminated: np.ndarray,
    gamma: float,
) -> np.ndarray:
    """The Double-DQN target ``r + γ (1 - done) Q_target(s', argmax_a' Q_online(s', a'))``.

    Args:
        next_q_online: ``[batch, num_actions]`` online-network values of the next states (they
            choose the action; ties go to the first, as ``argmax`` does).
        next_q_target: ``[batch, num_actions]`` target-network values (they evaluate it).
        rewards: ``[batch]``.
        terminated: ``[batch]``, 1.0 where the transition ended the episode.
        gamma: Discount.
    """
    chosen = next_q_online.argmax(axis=1)
    evaluated = next_q_target[np.arange(len(chosen)), chosen]
    return rewards + gamma * (1.0 - terminated) * evaluated


class DoubleDQN(MLPLearner):
    """An online Q-network, its target network and Adam's state, as flat float64 vectors.

    The online network is the :class:`MLPLearner` itself (``params``, ``layers``, Adam's
    moments); ``target`` is a second flat vector of the same layout, ``target_layers`` its views.

    Args:
        widths: ``inputs, hidden..., outputs``.
        params: The online network's flat parameters (copied); the target starts as a copy.
        args: Learning rate, weight decay, γ, τ.

    Raises:
        ValueError: Fewer than two widths, a width below 1, or ``params`` of the wrong length.
    """

    def __init__(self, widths: Sequence[int], params: np.ndarray, args: DDQNArgs) -> None:
        super().__init__(widths, params, args.learning_rate, args.weight_decay)
        self.args = args
        self.target = self.params.copy()
        self.target_layers = layer_views(self.target, self.widths)
        self.layout = layer_layout(self.widths)
        self._checked: dict[int, np.ndarray | None] = {}

    @classmethod
    def initial(cls, widths: Sequence[int], args: DDQNArgs, rng: np.random.Generator) -> DoubleDQN:
        """A fresh network (torch's ``Linear`` default: uniform in ``±1/sqrt(fan_in)``)."""
        return cls(widths, MLPLearner.initial_params(widths, rng), args)

    @classmethod
    def from_weights(
        cls, weights: Mapping[str, np.ndarray], prefix: str, args: DDQNArgs
    ) -> DoubleDQN:
        """A learner starting from exported ``prefix.i.weight``/``prefix.i.bias`` arrays.

        Raises:
            ValueError: No layer under ``prefix``, or shapes that do not chain (as
                :class:`~ns_pz.agents.learning.features.NumpyMLP`, which reads them).
        """
        layers = NumpyMLP(weights, prefix).layers  # [in, out] float64, checked
        widths = [layers[0][0].shape[0], *(w.shape[1] for w, _ in layers)]
        flat = np.concatenate([part.ravel() for layer in layers for part in layer])
        return cls(widths, flat, args)

    def sync_target(self) -> None:
        """The target network becomes a copy of the online one."""
        self.target[:] = self.params

    def q(self, x: np.ndarray, target: bool = False) -> np.ndarray:
        """Q-values of feature rows ``x`` (``[batch, inputs]`` or ``[inputs]``)."""
        return forward(self.target_layers if target else self.layers, self.as_input(x))

    def products(self, rows: int) -> np.ndarray | None:
        """:func:`products_for` this network on ``rows`` rows (asked once per count)."""
        if rows not in self._checked:
            self._checked[rows] = products_for(self.widths, rows)
        return self._checked[rows]

    def greedy(self, x: np.ndarray) -> int:
        """The online network's best action for one feature vector (ties: the first).

        Raises:
            ValueError: ``x`` is not one vector of the network's input size.
        """
        if type(x) is not np.ndarray or x.ndim != 1 or len(x) != self.widths[0]:
            x = self._checked_rows(x, 1)  # called at every training step: the check inline first
        blas = self.products(1)
        if blas is not None:
            return int(compiled_step().greedy_action(blas, self.layout, self.params, x))
        return int(self.q(x).argmax())

    def greedy_rows(self, x: np.ndarray) -> np.ndarray:
        """The online network's best action for each row of ``x`` (``[rows, inputs]``).

        Ties go to the first; compiled where :func:`products_for` allows (the same actions).

        Raises:
            ValueError: ``x`` is not ``[rows, inputs]`` for the network's input size.
        """
        x = self._checked_rows(x, 2)
        blas = self.products(len(x)) if len(x) else None
        if blas is not None:
            return compiled_step().greedy_rows(blas, self.layout, self.params, x)
        return self.q(x).argmax(axis=1)

    def _checked_rows(self, x: Any, ndim: int) -> np.ndarray:
        """``x`` as an array, refused unless ``ndim``-dimensional with the network's input size.

        The same on every path (compiled code would read memory unchecked).
        """
        x = np.asarray(x)
        if x.ndim != ndim or x.shape[-1] != self.widths[0]:
            raise ValueError(
                f"x has shape {x.shape}; the network takes "
                f"{'[inputs]' if ndim == 1 else '[rows, inputs]'} with inputs={self.widths[0]}"
            )
        return x

    def replay_step(self, buffer: ReplayBuffer, rng: np.random.Generator) -> float:
        """:meth:`gradient_step` on ``args.batch_size`` transitions sampled from ``buffer``.

        The sample is :meth:`ReplayBuffer.sample`'s (the same draw from ``rng``). Where the
        products can run compiled (:func:`products_for`) the whole step is one compiled call,
        with the same bits.

        Returns:
            The loss before the step.

        Raises:
            ValueError: The buffer's feature size is not the network's input size.
            IndexError: A stored action past the network's outputs (as NumPy's indexing).
        """
        index = buffer.sample_index(self.args.batch_size, rng)
        # one row: NumPy multiplies by it through other routines than the compiled step's
        blas = self.products(len(index)) if len(index) >= 2 else None
        if blas is None:
            return self.gradient_step(buffer.batch(index))
        self._checked_rows(buffer.features, 2)
        squares = self._whole_step(blas, index, buffer)
        # np.mean's own sum and division: the loss has the NumPy path's bits
        return float(np.add.reduce(squares)) / len(squares)

    def replay_steps(self, buffer: ReplayBuffer, rng: np.random.Generator, count: int) -> int:
        """``count`` :meth:`replay_step` calls (none while ``buffer`` is empty); returns how many.

        The same draws and bits, in one compiled call where the products allow (no loss is
        computed then).

        Raises:
            ValueError: The buffer's feature size is not the network's input size.
            IndexError: A stored action past the network's outputs (as NumPy's indexing); the
                steps before it stand and are counted.
        """
        if not buffer.size or count <= 0:
            return 0
        rows = self.args.batch_size
        blas = self.products(rows) if rows >= 2 else None
        if blas is None:
            for _ in range(count):
                self.replay_step(buffer, rng)
            return count
        self._checked_rows(buffer.features, 2)
        beta1, beta2 = ADAM_BETAS
        steps = range(self.steps + 1, self.steps + count + 1)
        # Python's float powers, as _whole_step's (numba's integer power rounds otherwise)
        corrections1 = np.array([1.0 - beta1**step for step in steps])
        root_corrections2 = np.array([math.sqrt(1.0 - beta2**step) for step in steps])
        done = np.zeros(1, dtype=np.int64)
        try:
            compiled_step().replay_steps(  # type: ignore[union-attr]  # products: numba is there
                blas, self.layout, self.params, self.grad, self.m, self.v, self.target,
                buffer.size, rows, buffer.features, buffer.actions, buffer.rewards,
                buffer.next_features, buffer.terminated, self.args.gamma, self.learning_rate,
                self.weight_decay, beta1, beta2, ADAM_EPS, corrections1, root_corrections2,
                self.args.tau, rng, done,
            )  # fmt: skip
        finally:
            self.steps += int(done[0])
        return count

    def _whole_step(self, blas: np.ndarray, index: np.ndarray, buffer: ReplayBuffer) -> Any:
        """The compiled gradient step on ``buffer``'s rows ``index``: the squared TD errors.

        ``steps`` counts it only once it has run (a bad stored action raises first).
        """
        beta1, beta2 = ADAM_BETAS
        steps = self.steps + 1
        squares = compiled_step().ddqn_step(  # type: ignore[union-attr]  # products: numba is there
            blas, self.layout, self.params, self.grad, self.m, self.v, self.target, index,
            buffer.features, buffer.actions, buffer.rewards, buffer.next_features,
            buffer.terminated, self.args.gamma, self.learning_rate, self.weight_decay, beta1,
            beta2, ADAM_EPS, 1.0 - beta1**steps, math.sqrt(1.0 - beta2**steps), self.args.tau,
        )  # fmt: skip
        self.steps = steps
        return squares

    def loss_and_gradient(self, batch: Batch) -> float:
        """The TD loss of ``batch`` (MSE to the Double-DQN target); its gradient in ``grad``."""
        next_features = self.as_input(batch.next_features)
        next_online = self.q(next_features)
        next_target = self.q(next_features, target=True)
        hidden = self.forward(batch.features)
        kernels = compiled_step()
        if kernels is None:
            y = double_dqn_target(
                next_online,
                next_target,
                batch.rewards.astype(np.float64),
                batch.terminated.astype(np.float64),
                self.args.gamma,
            )
            rows = np.arange(len(y))
            error = hidden[-1][rows, batch.actions] - y
            delta = np.zeros_like(hidden[-1])
            delta[rows, batch.actions] = 2.0 * error / len(y)
            self.backward(hidden, delta)
            return float(np.mean(error * error))
        squares = np.empty(len(hidden[-1]))
        delta = np.empty_like(hidden[-1])
        kernels.td_delta(
            hidden[-1],
            next_online,
            next_target,
            batch.actions,
            batch.rewards,
            batch.terminated,
            self.args.gamma,
            delta,
            squares,
        )
        self.backward(hidden, delta, flushed=True)
        # np.mean's own sum and division: the loss has the NumPy path's bits
        return float(np.add.reduce(squares)) / len(squares)

    def gradient_step(self, batch: Batch) -> float:
        """One Adam step on the TD loss of ``batch``, then the Polyak update of the target.

        The target moves ``target <- τ online + (1 - τ) target`` (subnormals flushed, as the
        online network's are). Where numba is installed the elementwise parts run compiled
        (:mod:`._mlp_kernels`), with the same bits.

        Returns:
            The loss before the step.
        """
        loss = self.loss_and_gradient(batch)
        kernels = compiled_step()
        if kernels is None:
            self.adam_step()
            self.target *= 1.0 - self.args.tau
            self.target += self.args.tau * self.params
            flush_subnormals(self.target)
            return loss
        beta1, beta2 = ADAM_BETAS
        self.steps += 1
        kernels.adam_polyak(
            self.params,
            self.grad,
            self.m,
            self.v,
            self.target,
            self.learning_rate,
            self.weight_decay,
            beta1,
            beta2,
            ADAM_EPS,
            1.0 - beta1**self.steps,
            math.sqrt(1.0 - beta2**self.steps),
            self.args.tau,
        )
        return loss

    def export(self, prefix: str) -> dict[str, np.ndarray]:
        """The online network as ``{prefix.i.weight, prefix.i.bias}`` (torch's layout)."""
        return export_layers(self.layers, prefix)


@functools.cache
def compiled_step() -> ModuleType | None:
    """The compiled elementwise parts of a gradient step (:mod:`._mlp_kernels`); None: no numba."""
    if not numba_available():
        return None
    return importlib.import_module("ns_pz.agents.learning._mlp_kernels")


def warm_up() -> None:
    """Load the compiled step's kernels now, where numba and NumPy's OpenBLAS are.

    A benchmark worker's head start: loading them costs about 0.4 s once a process on the
    development machine, before the first network's training, fine-tuning or greedy action.
    """
    learner = new_learner(2, 2, DDQNArgs(hidden=(2,), batch_size=2), 0)
    if learner.products(2) is None or learner.products(1) is None:
        return
    learner.greedy(np.zeros(2, dtype=np.float32))
    learner.greedy_rows(np.zeros((2, 2), dtype=np.float32))


def layer_layout(widths: Sequence[int]) -> np.ndarray:
    """Each layer's ``(matrix offset, in, out, bias offset)`` in the flat parameters.

    ``[layers, 4]`` int64, for compiled code; the layout is
    :func:`~ns_pz.agents.learning.mlp.layer_views`'.
    """
    rows, at = [], 0
    for a, b in zip(widths[:-1], widths[1:], strict=True):
        rows.append((at, a, b, at + a * b))
        at += a * b + b
    return np.array(rows, dtype=np.int64)


def products_for(widths: Sequence[int], rows: int) -> np.ndarray | None:
    """NumPy's BLAS routines for compiled code on the MLP ``widths`` and ``rows`` rows, or None.

    ``rows`` rows: forward passes (greedy actions) on that many, and for 2 rows or more a
    gradient step on a batch of that many. None unless numba is installed, NumPy's OpenBLAS is
    found (:func:`~ns_pz.agents.learning.numpy_blas.blas_routines`), ``rows`` is at least 1,
    every width at least 2 (NumPy multiplies by a vector through other routines), and a check
    on random data, once per shape and row count, gave NumPy's bits
    (:func:`_agrees_with_numpy`).
    """
    if compiled_step() is None or min(widths) < 2 or rows < 1:
        return None
    return _checked_products(tuple(widths), rows)


@functools.lru_cache(maxsize=1024)
def _checked_products(widths: tuple[int, ...], rows: int) -> np.ndarray | None:
    blas = blas_routines()
    if blas is None or not _agrees_with_numpy(blas, widths, rows):
        return None
    return blas


def _agrees_with_numpy(blas: np.ndarray, widths: tuple[int, ...], rows: int) -> bool:
    """Whether compiled forward passes on ``rows`` rows, and steps on batches of them, are NumPy's.

    Forward passes on random rows (one row also as a vector, as a greedy action takes it);
    then, for 2 rows or more, two learners from the same random weights take three steps on
    one random buffer, one through :meth:`DoubleDQN.gradient_step`'s NumPy products, one
    compiled. Every output, weight, moment and gradient is compared bit for bit.
    """
    kernels = compiled_step()
    rng = np.random.default_rng(0)
    args = DDQNArgs(hidden=widths[1:-1], batch_size=max(rows, 2), weight_decay=1e-4)
    numpy_learner = DoubleDQN(widths, MLPLearner.initial_params(widths, rng), args)
    layout, params = numpy_learner.layout, numpy_learner.params
    with one_blas_thread():
        for _ in range(3):
            x = rng.normal(size=(rows, widths[0])).astype(np.float32)
            got = kernels.forward_rows(blas, layout, params, x.astype(np.float64))
            shapes = (x, x[0]) if rows == 1 else (x,)
            for shaped in shapes:
                expected = forward(numpy_learner.layers, numpy_learner.as_input(shaped))
                if not np.array_equal(expected.reshape(got.shape), got):
                    return False
        if rows == 1:
            return True
        compiled = DoubleDQN(widths, numpy_learner.params, args)
        size = min(4 * rows, 256)  # sampled with replacement: a batch may outnumber it
        buffer = ReplayBuffer(size, widths[0])
        for _ in range(size):
            x, next_x = rng.normal(size=(2, widths[0])).astype(np.float32)
            buffer.add(x, int(rng.integers(widths[-1])), float(rng.normal()), next_x, False)
        for _ in range(3):
            index = rng.integers(buffer.size, size=rows)
            numpy_learner.gradient_step(buffer.batch(index))
            compiled._whole_step(blas, index, buffer)
    names = ("params", "grad", "m", "v", "target")
    return all(np.array_equal(getattr(numpy_learner, n), getattr(compiled, n)) for n in names)


def new_learner(inputs: int, num_actions: int, args: DDQNArgs, seed: int) -> DoubleDQN:
    """A fresh learner for ``inputs`` features and ``num_actions`` actions, drawn from ``seed``.

    Raises:
        ValueError: ``args.hidden`` is None (fill it in with :meth:`DDQNArgs.for_family`).
    """
    if args.hidden is None:
        raise ValueError(f"args.hidden={args.hidden!r} must be filled in (DDQNArgs.for_family)")
    widths = [inputs, *args.hidden, num_actions]
    return DoubleDQN.initial(widths, args, np.random.default_rng(seed))


def train_ddqn(
    env: NSGymEnv,
    args: DDQNArgs,
    seed: int,
    progress: Callable[[int, int], bool] | None = None,
) -> tuple[dict[str, np.ndarray], dict]:
    """Train a Double DQN in ``env`` (a stationary env at θ_0) for ``args.total_steps`` steps.

    Steps go to ``env.process`` directly, not through ``env.step``: the same transitions, but
    no rendering and no subclass's ``step`` (resets still go through ``env.reset``).

    Everything random comes from ``seed``, split by :func:`training_seeds` into independent
    streams: the env's episodes, ε-greedy and replay sampling (a numpy generator), the network
    initialisation.

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
    rng, env_seed, init_seed = training_seeds(seed)
    start = time.perf_counter()
    learner = new_learner(feature_size(space), num_actions, args, init_seed)
    buffer = ReplayBuffer(args.buffer_size, feature_size(space))
    returns: list[float] = []
    episode_return = 0.0

    # The loop drives the env's process itself: the view's step would also build the
    # observation's notification arrays and the info dict, which training never reads (an env
    # step took 4.0 µs through the view, 2.5 µs so, on FrozenLake). The dynamics are the same
    # calls, in the same order.
    process, check, observe = env.process, env.family.check_action, env.family.observe
    observation, _ = env.reset(seed=env_seed)
    x = features(space, observation["state"])
    for step in range(args.total_steps):
        # ε-greedy action, ε decaying linearly to its floor
        fraction = min(1.0, step / max(1.0, args.exploration_fraction * args.total_steps))
        epsilon = args.epsilon_start + fraction * (args.epsilon_end - args.epsilon_start)
        if rng.random() < epsilon:
            action = int(rng.integers(num_actions))
        else:
            action = learner.greedy(x)

        reward, terminated, truncated = process.transition(check(action))
        if not process.done:
            process.play_until(DECISION)
        next_x = features(space, observe(process.state))
        buffer.add(x, action, float(reward), next_x, bool(terminated))
        x = next_x
        episode_return += float(reward)
        if terminated or truncated:
            returns.append(episode_return)
            episode_return = 0.0
            observation, _ = env.reset()
            x = features(space, observation["state"])

        # a gradient step every `train_every` steps once the buffer holds a batch
        if step >= args.learning_starts and step % args.train_every == 0:
            learner.replay_step(buffer, rng)
        if progress is not None and progress(step + 1, args.total_steps):
            break

    info: dict[str, Any] = {
        "seconds": time.perf_counter() - start,
        "episodes": len(returns),
        "last_returns_mean": float(np.mean(returns[-20:])) if returns else None,
        "args": asdict(args),
    }
    return learner.export("q"), info
