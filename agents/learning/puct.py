"""PUCT: AlphaZero's search, guided by a policy/value function (Silver et al.).

A search function like :func:`ns_pz.agents.search.mcts.uct` (``search(model, root_state, rng)``
with its settings bound), returning the same :class:`SearchResult`:

* a node is created with ``(P, v) = evaluate(state)``; every action's Q starts at ``v``
  (first-play value = the node's own value); at the root the priors are mixed with Dirichlet
  noise, ``(1 - ε) P + ε Dir(α)``;
* selection: ``argmax_a Q(n, a) + c P(n, a) sqrt(1 + N(n)) / (1 + N(n, a))``, ties uniform;
  with ``normalise_q`` (MuZero's rule) Q is first min-max scaled by the smallest and largest
  value backed up in the tree so far, so ``c`` means the same whatever the reward scale
  (CliffWalking's ±100 otherwise swamps the prior term and the root noise entirely);
* a chance node (n, a) has one child per sampled next state; a simulation descends until it
  creates a node, reaches a terminal node or has descended ``depth`` levels, and takes the
  node's value as the leaf value;
* a terminal node's value is 0: the reward of entering it is already on the edge, added by the
  backup ``G <- r + γ G`` (the in-tree rewards are backed up, as AlphaZero's code does);
* the action played is the most visited one; the self-play targets are the visit
  distribution at a temperature and the visit-weighted root Q.

Two paths, as for UCT; with numba installed the search runs compiled
(:mod:`ns_pz.agents.learning._puct_kernels`) wherever it can, building the same tree as the
Python path for the same generators. On a tabular model the frozen network is first tabulated
over the states (:class:`TabularEvaluation`, one batched forward pass). On a model whose family
has a compiled step over state vectors and observes the state vector as float32 (CartPole) the
network runs inside the kernel (:class:`VectorEvaluation`); so that both paths build the same
tree, the Python path then evaluates the network with the kernel's own forward pass, not
numpy's (whose matrix products round differently). The network keeps its evaluations of its
last compiled search (:attr:`PolicyValueFunction.search_memo`), and the next search takes a
node's from there when its network input is the same bits: along an episode whose model
predicts the real next state, the next tree runs through much of the last one. On CartPole at
the specs' full size (500 simulations) a fresh decision takes about 2 ms compiled against
50-90 ms in Python (``benchmarks/bench_search.py``); along an episode of ``cartpole-single``'s
WN column with its trained network, about 1 ms against 2 ms without the memo
(``benchmarks/bench_trial_costs.py``, ``docs/speed.md``).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
from gymnasium import spaces
from ns_pz.agents.learning.features import NumpyMLP, features
from ns_pz.agents.search.compiled import (
    CompiledModel,
    TabularData,
    compile_model,
    kernels,
    numba_available,
)
from ns_pz.agents.search.mcts import num_actions_of, uniform_index
from ns_pz.agents.search.types import SearchResult

from ns_pz.checks import count

Evaluation = Callable[[Any], tuple[np.ndarray, float]]
"""``evaluate(state) -> (priors [num_actions] summing to 1, value)`` of a model state."""


class PolicyValueFunction:
    """A trained policy/value network as numpy: ``(softmax priors, value)`` of an observation.

    The weights are fixed once it is built (:meth:`packed` and the search memo rely on it).

    Args:
        weights: Exported ``trunk.*``, ``policy.0.*`` and ``value.0.*`` arrays.
        observation_space: The base environment's observation space.
    """

    def __init__(self, weights: Mapping[str, np.ndarray], observation_space: Any) -> None:
        self.trunk = NumpyMLP(weights, "trunk")
        self.policy = NumpyMLP(weights, "policy")
        self.value = NumpyMLP(weights, "value")
        self.space = observation_space
        self._packed: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.search_memo: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        """The compiled search's last evaluations, ``(inputs, priors, values)``: the next
        search takes a node's from here when its input is the same bits (see
        :func:`ns_pz.agents.learning._puct_kernels.puct_vector`)."""

    def __call__(self, observation: Any) -> tuple[np.ndarray, float]:
        """Priors ``[num_actions]`` and the value of one base observation."""
        priors, values = self.batch(features(self.space, observation)[None, :])
        return priors[0], float(values[0])

    def batch(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Priors ``[batch, num_actions]`` and values ``[batch]`` of feature rows ``x``."""
        h = np.maximum(self.trunk(x), 0.0)
        logits = self.policy(h)
        priors = np.exp(logits - logits.max(axis=1, keepdims=True))
        return priors / priors.sum(axis=1, keepdims=True), self.value(h)[:, 0]

    def __getstate__(self) -> dict[str, Any]:
        """The state to pickle, without the packed weights (see :meth:`packed`)."""
        return {**self.__dict__, "_packed": None}

    def packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The layers as flat arrays for compiled code: ``(weights, layout, parts)``.

        ``weights`` (float64) holds each layer's matrix ``[in, out]`` row-major, then its bias;
        ``layout`` ``[num_layers, 4]`` (int64) is per layer ``(matrix offset, in, out, bias
        offset)``, the trunk's layers first, then the policy head's, then the value head's;
        ``parts`` ``[3]`` (int64) counts the layers of each. Built once, then shared.

        ``weights`` starts on a 64-byte boundary and each matrix on a multiple of 8 floats
        (zeros fill the gaps), so the compiled forward pass's vector loads of a row never
        straddle two cache lines where a layer's width is a multiple of 8 (such loads made the
        trunk's 128 x 128 layer 0.95 against 0.49 µs). A pickled copy leaves them out (an
        unpickled array lies where it lies) and packs again when asked.
        """
        if self._packed is None:
            rows: list[tuple[int, int, int, int]] = []
            at = 0
            mlps = (self.trunk, self.policy, self.value)
            layers = [layer for mlp in mlps for layer in mlp.layers]
            for w, b in layers:
                at = -(-at // _FLOATS_PER_LINE) * _FLOATS_PER_LINE
                rows.append((at, w.shape[0], w.shape[1], at + w.size))
                at += w.size + b.size
            weights = _aligned_zeros(at)
            for (w, b), (start, _, _, bias) in zip(layers, rows, strict=True):
                weights[start:bias] = w.ravel()
                weights[bias : bias + b.size] = b
            parts = np.array([len(mlp.layers) for mlp in mlps], dtype=np.int64)
            self._packed = (weights, np.array(rows, dtype=np.int64), parts)
        return self._packed


_ALIGNMENT = 64
"""Bytes of a cache line: where :meth:`PolicyValueFunction.packed` starts its weights."""
_FLOATS_PER_LINE = _ALIGNMENT // 8


def _aligned_zeros(size: int) -> np.ndarray:
    """``size`` float64 zeros whose first lies on a ``_ALIGNMENT``-byte boundary."""
    buffer = np.zeros(size + _FLOATS_PER_LINE)
    skip = (-buffer.ctypes.data % _ALIGNMENT) // 8
    return buffer[skip : skip + size]


class VectorEvaluation:
    """``evaluate(state)``: the network on the family's observation of a model state.

    With numba installed the forward pass is compiled code
    (:func:`ns_pz.agents.learning._puct_kernels.network`), the arithmetic of the compiled search,
    so the Python and compiled searches build the same tree; without numba it is the function's
    numpy forward pass (equal to about 1e-12, not bit for bit).

    Args:
        function: The network.
        observe: ``observe(state) -> observation`` (the family's).
    """

    def __init__(self, function: PolicyValueFunction, observe: Callable[[Any], Any]) -> None:
        self.function = function
        self.observe = observe
        self._network = _kernels().network if numba_available() else None

    def __call__(self, state: Any) -> tuple[np.ndarray, float]:
        """Priors ``[num_actions]`` and the value of ``state``.

        Raises:
            ValueError: The observation's features do not fit the network's input.
        """
        observation = self.observe(state)
        if self._network is None:
            return self.function(observation)
        x = features(self.function.space, observation).astype(np.float64)
        if x.shape != (self.function.trunk.input_size,):
            raise ValueError(
                f"the observation has {x.size} features; the network takes "
                f"{self.function.trunk.input_size}"
            )
        priors, value = self._network(*self.function.packed(), x)
        return priors, float(value)


@dataclass(frozen=True)
class TabularEvaluation:
    """A policy/value network tabulated over the states of a tabular model.

    Attributes:
        priors: ``[num_states, num_actions]``, rows sum to 1.
        values: ``[num_states]``.
    """

    priors: np.ndarray
    values: np.ndarray

    def __call__(self, state: Any) -> tuple[np.ndarray, float]:
        """The row of ``state``."""
        return self.priors[state], float(self.values[state])


@dataclass(frozen=True)
class PUCTTree:
    """The root statistics of one PUCT search.

    Attributes:
        visits: ``[num_actions]`` N(root, a).
        q: ``[num_actions]`` Q(root, a) (the root's value where unvisited).
        root_value: The network's value of the root.
        num_nodes: Decision nodes created, the root included.
        simulated_steps: Model transitions made.
        priors: ``[num_actions]`` the root's priors as searched: the network's, mixed with
            the Dirichlet noise (the only node that gets it).
        remembered: Nodes whose priors and value came from the network's memo of its last
            search rather than a forward pass (compiled search on vector states only).
    """

    visits: np.ndarray
    q: np.ndarray
    root_value: float
    num_nodes: int
    simulated_steps: int
    priors: np.ndarray
    remembered: int = 0

    def policy_target(self, temperature: float) -> np.ndarray:
        """``N(root, ·)^(1/T)`` normalised (computed in log space, so small T is safe)."""
        logs = np.where(self.visits > 0, np.log(np.maximum(self.visits, 1)), -np.inf)
        scaled = np.exp((logs - logs.max()) / temperature)
        return scaled / scaled.sum()

    def value_target(self) -> float:
        """The visit-weighted root Q, ``Σ_a N(root, a) Q(root, a) / Σ_a N(root, a)``."""
        return float(np.dot(self.visits, self.q) / self.visits.sum())


class _Node:
    __slots__ = ("state", "terminal", "value", "priors", "n", "visits", "w", "q", "children")

    def __init__(
        self, state: Any, terminal: bool, priors: np.ndarray, value: float, num_actions: int
    ) -> None:
        self.state = state
        self.terminal = terminal
        self.value = value
        self.priors = priors
        self.n = 0
        self.visits = np.zeros(num_actions, dtype=np.int64)
        self.w = np.zeros(num_actions)
        self.q = np.full(num_actions, value)
        self.children: list[dict[Any, _Node]] = [{} for _ in range(num_actions)]


def _select(node: _Node, c: float, rng: np.random.Generator, bounds: list[float] | None) -> int:
    q = node.q
    if bounds is not None and bounds[1] > bounds[0]:
        q = (q - bounds[0]) / (bounds[1] - bounds[0])
    scores = q + c * node.priors * math.sqrt(1 + node.n) / (1 + node.visits)
    best = np.flatnonzero(scores == scores.max())
    return int(best[0] if len(best) == 1 else best[uniform_index(rng, len(best))])


@dataclass(frozen=True)
class PUCTSettings:
    """PUCT's hyper-parameters.

    Attributes:
        iterations: Simulations (>= 1).
        depth: Most levels a simulation descends through existing nodes.
        c: Exploration constant.
        gamma: Discount.
        dirichlet_alpha: Concentration of the root noise.
        noise: Weight ε of the root noise (0: none, and no draw from the generator).
        normalise_q: Min-max scale Q in the selection by the values backed up so far.
    """

    iterations: int
    depth: int
    c: float
    gamma: float
    dirichlet_alpha: float = 1.0
    noise: float = 0.0
    normalise_q: bool = False

    def __post_init__(self) -> None:
        """Refuse counts the kernels would size their arrays from wrongly.

        Raises:
            ValueError: ``iterations`` below 1 or ``depth`` below 0 (or not integers).
        """
        count("iterations", self.iterations, 1)
        count("depth", self.depth, 0)


def puct_tree(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    evaluate: Evaluation,
    settings: PUCTSettings,
    backend: str = "auto",
) -> PUCTTree:
    """Run PUCT from ``root_state`` in ``model`` (``model.transition``; its state is untouched).

    Args:
        model: A planning model with a ``Discrete`` action space.
        root_state: The state to decide in.
        rng: The search generator (root noise, tie-breaks).
        evaluate: ``evaluate(state) -> (priors, value)``.
        settings: The hyper-parameters.
        backend: ``"auto"`` (compiled where numba is installed and the model and evaluation
            allow it: a tabular model with a :class:`TabularEvaluation`, or a model of a family
            with a compiled vector step and a float32 observation, such as CartPole, with a
            :class:`VectorEvaluation` of its family's observation), ``"compiled"`` (fail if not
            possible) or ``"python"``.

    Raises:
        ValueError: An unknown backend, ``"compiled"`` where it is not possible (the message
            says why), or ``evaluate`` gives priors of another length than the action space.
    """
    compiled = _compiled(model, evaluate, backend)
    c, gamma, depth = settings.c, settings.gamma, settings.depth
    noise, dirichlet_alpha = settings.noise, settings.dirichlet_alpha
    num_actions = num_actions_of(model)
    priors, value = evaluate(root_state)
    if len(priors) != num_actions:
        raise ValueError(f"evaluate gave {len(priors)} priors for {num_actions} actions")
    if noise > 0.0:
        priors = (1.0 - noise) * priors + noise * rng.dirichlet(
            np.full(num_actions, dirichlet_alpha)
        )
    if compiled is not None:
        search = (settings.iterations, depth, float(c), float(gamma), settings.normalise_q)
        generators = kernels().inline_streams(compiled.rng, rng)  # PCG64 drawn inline
        root_priors = np.asarray(priors, dtype=np.float64)
        if isinstance(evaluate, VectorEvaluation):
            function = evaluate.function
            vector = compiled.family.to_vector(root_state)
            vector = np.ascontiguousarray(vector, dtype=np.float64)
            network = (root_priors, float(value), *function.packed())
            memo = function.search_memo or _empty_memo(len(vector), num_actions)
            visits, q, nodes, simulated, *kept, found = _kernels().puct_vector(
                compiled.data, vector, *network, *memo, *search, *generators
            )
            function.search_memo = tuple(kept)  # type: ignore[assignment]  # three arrays
            return PUCTTree(visits, q, value, int(nodes), int(simulated), priors, int(found))
        table = (evaluate.priors, evaluate.values)  # type: ignore[attr-defined]  # checked
        visits, q, nodes, simulated = _kernels().puct_tabular(
            compiled.data, int(root_state), root_priors, *table, *search, *generators
        )
        return PUCTTree(visits, q, value, int(nodes), int(simulated), priors)
    root = _Node(root_state, False, priors, value, num_actions)
    bounds = [np.inf, -np.inf] if settings.normalise_q else None
    nodes, simulated = 1, 0
    for _ in range(settings.iterations):
        node, path, level = root, [], 0
        while True:
            action = _select(node, c, rng, bounds)
            state, reward, done = model.transition(node.state, action)
            simulated += 1
            path.append((node, action, float(reward)))
            child = node.children[action].get(state)
            if child is None:
                if done:
                    child = _Node(state, True, np.full(num_actions, 1.0 / num_actions), 0.0, 0)
                else:
                    child_priors, child_value = evaluate(state)
                    child = _Node(state, False, child_priors, child_value, num_actions)
                node.children[action][state] = child
                nodes += 1
                leaf = child.value
                break
            node = child
            if node.terminal or level == depth:
                leaf = node.value
                break
            level += 1
        for n, a, reward in reversed(path):
            leaf = reward + gamma * leaf
            n.visits[a] += 1
            n.w[a] += leaf
            n.q[a] = n.w[a] / n.visits[a]
            n.n += 1
            if bounds is not None:
                bounds[0], bounds[1] = min(bounds[0], n.q[a]), max(bounds[1], n.q[a])
    return PUCTTree(root.visits.copy(), root.q.copy(), value, nodes, simulated, root.priors)


def puct(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    evaluate: Evaluation,
    settings: PUCTSettings,
    backend: str = "auto",
) -> SearchResult:
    """One PUCT decision: the most visited root action (ties uniform); see :func:`puct_tree`."""
    tree = puct_tree(model, root_state, rng, evaluate, settings, backend)
    best = np.flatnonzero(tree.visits == tree.visits.max())
    action = int(best[0] if len(best) == 1 else best[uniform_index(rng, len(best))])
    stats = {
        "iterations": float(settings.iterations),
        "nodes": float(tree.num_nodes),
        "simulated_steps": float(tree.simulated_steps),
        "remembered": float(tree.remembered),
    }
    return SearchResult(action, tree.q.copy(), tree.visits.copy(), stats)


def model_evaluation(function: PolicyValueFunction, model: Any) -> Evaluation:
    """``evaluate(state)`` for states of ``model``: the network on the family's observation.

    For a tabular model (an outcome table and a ``Discrete`` observation of the state index)
    the network is tabulated over all states at once (:class:`TabularEvaluation`); for any other
    it is a :class:`VectorEvaluation` of the family's ``observe``.
    """
    space = function.space
    if hasattr(model, "outcomes") and isinstance(space, spaces.Discrete) and space.start == 0:
        priors, values = function.batch(np.eye(int(space.n), dtype=np.float32))
        return TabularEvaluation(priors, values)
    return VectorEvaluation(function, model.family.observe)


def _empty_memo(dim: int, num_actions: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A search memo that remembers nothing yet."""
    return np.empty((0, dim)), np.empty((0, num_actions)), np.empty(0)


def _compiled(model: Any, evaluate: Evaluation, backend: str) -> CompiledModel | None:
    """The compiled model to search (kernel by ``evaluate``'s type), or None for Python."""
    compiled = compile_model(model, backend)  # checks the backend's name and numba
    if compiled is None:
        return None
    reason = _not_compilable(compiled, model, evaluate)
    if reason is None:
        return compiled
    if backend == "compiled":
        raise ValueError(f"backend='compiled' is not possible: {reason}")
    return None


def _not_compilable(compiled: CompiledModel, model: Any, evaluate: Evaluation) -> str | None:
    """Why compiled PUCT cannot search ``model`` with ``evaluate``; None if it can."""
    if isinstance(compiled.data, TabularData):
        if isinstance(evaluate, TabularEvaluation):
            return None
        return (
            "compiled PUCT on a tabular model needs a TabularEvaluation (model_evaluation gives "
            f"one), not {type(evaluate).__name__}"
        )
    family = type(model.family).__name__
    data_cls = type(compiled.data)
    if not isinstance(evaluate, VectorEvaluation):
        return (
            f"compiled PUCT on {family} needs a VectorEvaluation of a network (model_evaluation "
            f"gives one), not {type(evaluate).__name__}"
        )
    if not compiled.family.float32_observation:
        return (
            f"{family} is not registered with float32_observation=True, so its network input "
            "cannot be computed inside the kernel"
        )
    if getattr(evaluate.observe, "__func__", None) is not type(model.family).observe:
        return f"the VectorEvaluation observes with something other than {family}.observe"
    if not isinstance(evaluate.function.space, spaces.Box):
        return f"the network takes a {type(evaluate.function.space).__name__} observation"
    if not data_cls.__module__.startswith("ns_pz."):
        return (
            f"{data_cls.__qualname__} is defined outside ns_pz (compiled PUCT, cached on disk, "
            "serves the compiled steps of ns_pz's own families)"
        )
    return None


def _kernels() -> ModuleType:
    kernels()  # the compiled steps register first
    return importlib.import_module("ns_pz.agents.learning._puct_kernels")
