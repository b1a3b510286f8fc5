"""MCTS: UCT with random rollouts (Kocsis & Szepesvári 2006), as the NS-Gym paper runs it.

Each decision builds a fresh tree from the root state and throws it away afterwards:

* decision nodes keep their own statistics N(n), N(n, a), Q(n, a) (no sharing between nodes
  with equal states, unlike NS-Gym's transposition table);
* a chance node (n, a) has one decision child per sampled next state (CartPole: exactly one);
* an action not yet tried at a node is tried first, chosen uniformly among the untried ones;
  otherwise UCB ``Q + c * sqrt(ln N(n) / N(n, a))``, ties broken uniformly;
* an iteration descends until it creates a node or reaches a terminal transition, then rolls
  out uniform random actions for at most ``depth`` steps (or to a terminal);
* the backup adds the in-tree rewards: ``G <- r + gamma * G`` up the path (NS-Gym drops them);
* the action played is the best mean Q at the root (``final="visits"``: the most visited).

Random choices come from the search generator ``rng``, one ``rng.random()`` per choice
(uniform index ``int(u * n)``), and transitions from the model's own generator. Two paths run
the same algorithm: the reference (pure Python, any planning model, through
``model.transition``) and the compiled one (numba kernels over arrays; tabular models and
CartPole built in, see :mod:`ns_pz.agents.search.compiled`). For the same generators both build
the same tree, node for node.

Usage::

    agent = MCTS(iterations=300, depth=100, c=math.sqrt(2), gamma=0.99)
    run_episode(ns_pz.make_gym("ns_pz/FrozenLake-v0"), agent, seed=0)

    # or the search function itself
    result = uct(model, model.get_state(), rng, iterations=300, depth=100)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any

import numpy as np
from gymnasium import spaces
from ns_pz.agents.search.compiled import BACKENDS, CompiledModel, compile_model, kernels_for
from ns_pz.agents.search.types import SearchAgent, SearchResult

FINALS = ("value", "visits")


class NodeStates(Sequence[Any]):
    """A compiled tree's node states, each converted from its kernel row only when read.

    The agents read only the root's statistics; converting every node's row up front (CartPole:
    a tuple of four floats for each of the 300 nodes of a paper-size decision) was a fifth of a
    PA-MCTS decision. Equal to the tuple of the same states, as the reference tree holds them.

    Args:
        rows: ``[num_nodes, state_size]`` the kernel's state vectors (not copied; not to be
            written afterwards).
        from_vector: The family's conversion of one row to its state value.
    """

    def __init__(self, rows: np.ndarray, from_vector: Callable[[np.ndarray], Any]) -> None:
        self._rows, self._from_vector = rows, from_vector

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self._from_vector(row) for row in self._rows[index])
        return self._from_vector(self._rows[index])

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (tuple, NodeStates)):
            return tuple(self) == tuple(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # equal to a tuple, so not hashable like one

    def __repr__(self) -> str:
        return f"NodeStates({len(self)} nodes)"

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled as the tuple it equals (a family's converter may be a lambda)."""
        return (tuple, (tuple(self),))


@dataclass(frozen=True)
class UCTTree:
    """The statistics of one UCT search; node 0 is the root, nodes in creation order.

    Attributes:
        parent: ``[num_nodes]`` index of each node's parent decision node (-1 for the root).
        parent_action: ``[num_nodes]`` the action leading to the node (-1 for the root).
        states: The state of each node (the family's state values; from the compiled path a
            :class:`NodeStates`, converted when read).
        terminal: ``[num_nodes]`` whether the transition into the node ended the episode.
        node_visits: ``[num_nodes]`` N(n), backups through the node.
        visits: ``[num_nodes, num_actions]`` N(n, a).
        q: ``[num_nodes, num_actions]`` Q(n, a), mean discounted return (0 where unvisited).
        simulated_steps: Model transitions made, in the tree and in rollouts.
    """

    parent: np.ndarray
    parent_action: np.ndarray
    states: Sequence[Any]
    terminal: np.ndarray
    node_visits: np.ndarray
    visits: np.ndarray
    q: np.ndarray
    simulated_steps: int

    @property
    def num_nodes(self) -> int:
        """Decision nodes in the tree, the root included."""
        return len(self.states)


def check_uct_params(iterations: Any, depth: Any, c: Any, gamma: Any) -> None:
    """Validate UCT hyper-parameters.

    Raises:
        TypeError: A parameter has the wrong type (``iterations`` and ``depth`` are integers).
        ValueError: ``iterations < 1``, ``depth < 0``, ``c < 0`` or ``gamma`` outside [0, 1].
    """
    for name, value, low in (("iterations", iterations, 1), ("depth", depth, 0)):
        if isinstance(value, bool) or not isinstance(value, Integral):
            raise TypeError(f"{name}={value!r} must be an integer >= {low}")
        if value < low:
            raise ValueError(f"{name}={value!r} must be >= {low}")
    for name, value in (("c", c), ("gamma", gamma)):
        if isinstance(value, bool) or not isinstance(value, Real):
            raise TypeError(f"{name}={value!r} must be a real number")
    if not c >= 0.0 or math.isinf(c):
        raise ValueError(f"c={c!r} must be a finite number >= 0")
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma={gamma!r} must lie in [0, 1]")


def num_actions_of(model: Any) -> int:
    """The number of actions of a model with a ``Discrete`` action space.

    Raises:
        TypeError: The model has no discrete action space.
    """
    space = getattr(model, "action_space", None)
    if not isinstance(space, spaces.Discrete) or int(space.start) != 0:
        raise TypeError(
            f"UCT needs a model whose action_space is Discrete(n) starting at 0, got {space!r}"
        )
    return int(space.n)


def uniform_index(rng: np.random.Generator, n: int) -> int:
    """An index in ``range(n)`` from one ``rng.random()`` draw (as the compiled kernels do)."""
    index = int(rng.random() * n)
    return index if index < n else n - 1


def reference_uct(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    iterations: int,
    depth: int,
    c: float,
    gamma: float,
) -> UCTTree:
    """UCT in plain Python over ``model.transition(state, action)``; states must be hashable."""
    num_actions = num_actions_of(model)
    transition = model.transition
    states: list[Any] = [root_state]
    terminal = [False]
    parent, parent_action = [-1], [-1]
    node_visits = [0]
    visits: list[list[int]] = [[0] * num_actions]
    q: list[list[float]] = [[0.0] * num_actions]
    children: list[list[dict[Any, int]]] = [[{} for _ in range(num_actions)]]
    simulated = 0
    for _ in range(iterations):
        node, path, done = 0, [], False
        while not terminal[node]:
            action = _select(q[node], visits[node], node_visits[node], c, rng)
            state, reward, done = transition(states[node], action)
            simulated += 1
            path.append((node, action, reward))
            child = children[node][action].get(state)
            new = child is None
            if child is None:
                child = len(states)
                children[node][action][state] = child
                states.append(state)
                terminal.append(bool(done))
                parent.append(node)
                parent_action.append(action)
                node_visits.append(0)
                visits.append([0] * num_actions)
                q.append([0.0] * num_actions)
                children.append([{} for _ in range(num_actions)])
            node = child
            if new or done:
                break
        value = 0.0
        if not done:
            state, discount, steps = states[node], 1.0, 0
            while steps < depth:
                state, reward, rollout_done = transition(state, uniform_index(rng, num_actions))
                value += discount * reward
                discount *= gamma
                steps += 1
                if rollout_done:
                    break
            simulated += steps
        for n, a, reward in reversed(path):
            value = reward + gamma * value
            node_visits[n] += 1
            visits[n][a] += 1
            q[n][a] += (value - q[n][a]) / visits[n][a]
    return UCTTree(
        np.array(parent, dtype=np.int64),
        np.array(parent_action, dtype=np.int64),
        tuple(states),
        np.array(terminal, dtype=np.bool_),
        np.array(node_visits, dtype=np.int64),
        np.array(visits, dtype=np.int64).reshape(len(states), num_actions),
        np.array(q, dtype=np.float64).reshape(len(states), num_actions),
        simulated,
    )


def _select(
    q: list[float], visits: list[int], node_visits: int, c: float, rng: np.random.Generator
) -> int:
    untried = [a for a, n in enumerate(visits) if n == 0]
    if untried:
        return untried[uniform_index(rng, len(untried))]
    log_n = math.log(node_visits)
    best, ties = -math.inf, []
    for a, n in enumerate(visits):
        score = q[a] + c * math.sqrt(log_n / n)
        if score > best:
            best, ties = score, [a]
        elif score == best:
            ties.append(a)
    return ties[0] if len(ties) == 1 else ties[uniform_index(rng, len(ties))]


def compiled_uct(
    compiled: CompiledModel,
    root_state: Any,
    rng: np.random.Generator,
    iterations: int,
    depth: int,
    c: float,
    gamma: float,
) -> UCTTree:
    """UCT in the numba kernel; same tree as :func:`reference_uct` for the same generators.

    Generators on numpy's PCG64 are drawn from inline (:mod:`._pcg64`): the same numbers, and
    the generators end where they would have.
    """
    family = compiled.family
    module = kernels_for(type(compiled.data))
    result = module.uct(
        compiled.data,
        family.to_vector(root_state),
        compiled.num_actions,
        iterations,
        depth,
        float(c),
        float(gamma),
        *module.inline_streams(compiled.rng, rng),
    )
    parent, parent_action, states, terminal, node_visits, visits, q, _, simulated = result
    return UCTTree(
        parent,
        parent_action,
        NodeStates(states, family.from_vector),
        terminal,
        node_visits,
        visits,
        q,
        int(simulated),
    )


def uct_tree(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    *,
    iterations: int = 300,
    depth: int = 100,
    c: float = math.sqrt(2),
    gamma: float = 0.99,
    backend: str = "auto",
) -> UCTTree:
    """Run UCT from ``root_state`` and return the whole tree (see :func:`uct` for the arguments).

    Raises:
        TypeError, ValueError: Bad hyper-parameters, backend or model (see
            :func:`check_uct_params`, :func:`ns_pz.agents.search.compiled.compile_model`).
    """
    check_uct_params(iterations, depth, c, gamma)
    num_actions_of(model)
    compiled = compile_model(model, backend)
    if compiled is None:
        return reference_uct(model, root_state, rng, int(iterations), int(depth), c, gamma)
    return compiled_uct(compiled, root_state, rng, int(iterations), int(depth), c, gamma)


def uct(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    *,
    iterations: int = 300,
    depth: int = 100,
    c: float = math.sqrt(2),
    gamma: float = 0.99,
    final: str = "value",
    backend: str = "auto",
) -> SearchResult:
    """One UCT decision from ``root_state`` in ``model`` (the model's own state is untouched).

    Args:
        model: A planning model with a ``Discrete`` action space and ``transition(state,
            action) -> (next_state, reward, terminal)``.
        root_state: The state to decide in.
        rng: The search's generator (action choices, tie-breaks, rollout actions).
        iterations: m, simulations from the root (>= 1).
        depth: d, the most rollout steps after the tree (>= 0; 0 means no rollout).
        c: UCB exploration constant (>= 0).
        gamma: Discount in [0, 1], in the tree and in rollouts.
        final: ``"value"`` plays the best mean Q at the root (the paper's and NS-Gym's choice);
            ``"visits"`` plays the most visited action. Ties are broken uniformly with ``rng``.
        backend: ``"auto"`` (compiled where a compiled step exists and numba is installed),
            ``"compiled"`` (fail if not possible) or ``"python"`` (the reference path).

    Returns:
        The action, the root's Q (NaN where unvisited) and visit counts; ``stats`` has
        ``iterations``, ``nodes`` and ``simulated_steps``.
    """
    if final not in FINALS:
        raise ValueError(f"final={final!r} is not a final-action rule; allowed: {list(FINALS)}")
    tree = uct_tree(
        model,
        root_state,
        rng,
        iterations=iterations,
        depth=depth,
        c=c,
        gamma=gamma,
        backend=backend,
    )
    return result_of(tree, final, rng, iterations)


def result_of(tree: UCTTree, final: str, rng: np.random.Generator, iterations: int) -> SearchResult:
    """The decision a tree supports under ``final`` (ties broken with ``rng``)."""
    visits = tree.visits[0].copy()
    values = np.where(visits > 0, tree.q[0], np.nan)
    score = np.where(visits > 0, tree.q[0], -np.inf) if final == "value" else visits
    best = np.flatnonzero(score == score.max())
    action = int(best[0] if len(best) == 1 else best[uniform_index(rng, len(best))])
    stats = {
        "iterations": float(iterations),
        "nodes": float(tree.num_nodes),
        "simulated_steps": float(tree.simulated_steps),
    }
    return SearchResult(action, values, visits, stats)


class MCTS(SearchAgent):
    """The UCT agent: one fresh search per decision on the planning model handed over.

    Args:
        iterations: m, simulations per decision (paper: 300 FrozenLake, 1000 CliffWalking, 500
            Bridge, 300 CartPole).
        depth: d, rollout length cap (paper: 100, 200, 100, 500).
        c: UCB exploration constant (paper: sqrt(2)).
        gamma: Discount (paper: 0.99; CliffWalking 0.999; CartPole 0.5).
        final: ``"value"`` (best mean Q, the paper's) or ``"visits"`` (most visited).
        backend: ``"auto"``, ``"compiled"`` or ``"python"`` (see :func:`uct`).
        name: How the agent is called in reports.

    Raises:
        TypeError, ValueError: A hyper-parameter is out of range (checked here, not per step).
    """

    def __init__(
        self,
        iterations: int = 300,
        depth: int = 100,
        c: float = math.sqrt(2),
        gamma: float = 0.99,
        final: str = "value",
        backend: str = "auto",
        name: str | None = None,
    ) -> None:
        check_uct_params(iterations, depth, c, gamma)
        if final not in FINALS:
            raise ValueError(f"final={final!r} is not a final-action rule; allowed: {list(FINALS)}")
        if backend not in BACKENDS:
            raise ValueError(f"backend={backend!r} is not a backend; allowed: {list(BACKENDS)}")
        search = functools.partial(
            uct,
            iterations=iterations,
            depth=depth,
            c=c,
            gamma=gamma,
            final=final,
            backend=backend,
        )
        self.iterations, self.depth, self.c, self.gamma = iterations, depth, c, gamma
        self.final, self.backend = final, backend
        super().__init__(search, name=name or f"MCTS(m={iterations}, d={depth})")

    def __repr__(self) -> str:
        return (
            f"MCTS(iterations={self.iterations}, depth={self.depth}, c={self.c:.4g}, "
            f"gamma={self.gamma}, final={self.final!r}, backend={self.backend!r})"
        )
