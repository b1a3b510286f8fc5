"""Dirichlet transition learner over a tabular family's structural support (ADA-MCTS's M1).

The support of (s, a) is its outcome slots in the family's table (``next_states``, ``rewards``,
``terminals`` of shape ``[num_states, num_actions, num_outcomes]``, zero-probability slots
included). Slots of one (s, a) with the same (next state, reward, terminal) are one *atom*: an
observed transition identifies its atom, never which of the equal slots produced it.

Two ways to tie parameters:

* ``pooling="state_action"`` (ADA-MCTS's default): one Dirichlet per (s, a) over its atoms,
  prior ``prior`` per atom;
* ``pooling="shared"``: one Dirichlet over slot indices shared by every (s, a), prior ``prior``
  per slot. Right when θ is one global slip vector (FrozenLake, CliffWalking, Bridge): every
  step teaches every state. An observation matching several slots of (s, a) (a wall makes two
  slips land in the same cell) is split among them in proportion to the current posterior mean.

Uncertainties, per (s, a), of a Dirichlet with atom concentrations α (α_0 = Σ α):
epistemic ``EU = Σ_i Var(p_i) = (1 - Σ m_i²) / (α_0 + 1)`` with ``m = α / α_0`` and aleatoric
``AU = -Σ m_i log m_i`` (entropy of the posterior-mean kernel).
"""

from __future__ import annotations

import numpy as np

POOLINGS = ("state_action", "shared")


def atoms_of(next_states: np.ndarray, rewards: np.ndarray, terminals: np.ndarray) -> np.ndarray:
    """The atom of each slot: the first slot of its (s, a) with the same outcome.

    Returns:
        ``[num_states, num_actions, num_outcomes]`` int64 slot index of each slot's atom leader.
    """
    num_outcomes = next_states.shape[2]
    leader = np.broadcast_to(np.arange(num_outcomes), next_states.shape).copy()
    for k in range(num_outcomes - 1, 0, -1):
        for j in range(k - 1, -1, -1):
            same = (
                (next_states[..., j] == next_states[..., k])
                & (rewards[..., j] == rewards[..., k])
                & (terminals[..., j] == terminals[..., k])
            )
            leader[..., k] = np.where(same, j, leader[..., k])
    return leader


def aggregate(slot_values: np.ndarray, atoms: np.ndarray) -> np.ndarray:
    """Sum slot values into their atom leader's slot (other slots get 0); same shape."""
    shape = np.broadcast_shapes(slot_values.shape, atoms.shape)
    values = np.broadcast_to(slot_values, shape)
    out = np.zeros(shape)
    for k in range(shape[2]):
        for j in range(k + 1):
            out[..., j] += np.where(atoms[..., k] == j, values[..., k], 0.0)
    return out


def epistemic(atom_alpha: np.ndarray) -> np.ndarray:
    """``[S, A]`` summed posterior variances, given atom concentrations ``[S, A, K]``."""
    total = atom_alpha.sum(axis=2)
    mean = atom_alpha / total[..., None]
    return (1.0 - (mean * mean).sum(axis=2)) / (total + 1.0)


def entropy(atom_probs: np.ndarray) -> np.ndarray:
    """``[S, A]`` entropy (nats) of kernels given per atom, ``[S, A, K]``."""
    safe = np.where(atom_probs > 0, atom_probs, 1.0)
    return -(atom_probs * np.log(safe)).sum(axis=2)


class DirichletLearner:
    """Posterior over the transition kernel of a table's structure, updated per transition.

    Args:
        next_states: ``[S, A, K]`` the structure's next states.
        rewards: ``[S, A, K]`` the structure's rewards.
        terminals: ``[S, A, K]`` the structure's terminal flags.
        pooling: ``"state_action"`` or ``"shared"`` (see the module docstring).
        prior: Prior concentration per atom (``state_action``) or per slot (``shared``), > 0.

    Raises:
        ValueError: Unknown ``pooling`` or ``prior <= 0``.
    """

    def __init__(
        self,
        next_states: np.ndarray,
        rewards: np.ndarray,
        terminals: np.ndarray,
        pooling: str = "state_action",
        prior: float = 1.0,
    ) -> None:
        if pooling not in POOLINGS:
            raise ValueError(f"pooling={pooling!r} is not a pooling; allowed: {list(POOLINGS)}")
        if not prior > 0.0 or not np.isfinite(prior):
            raise ValueError(f"prior={prior!r} must be a finite number > 0")
        self.next_states = np.asarray(next_states)
        self.rewards = np.asarray(rewards)
        self.terminals = np.asarray(terminals)
        self.pooling = pooling
        self.prior = float(prior)
        self.atoms = atoms_of(self.next_states, self.rewards, self.terminals)
        num_outcomes = self.next_states.shape[2]
        self.is_leader = self.atoms == np.arange(num_outcomes)
        if pooling == "shared":
            self.alpha = np.full(num_outcomes, self.prior)
        else:
            self.alpha = np.where(self.is_leader, self.prior, 0.0)
        self.visits = np.zeros(self.next_states.shape[:2], dtype=np.int64)
        self.unexplained = 0

    def update(
        self, state: int, action: int, next_state: int, reward: float, terminal: bool
    ) -> bool:
        """Count one real transition; False (and nothing learned) if no slot explains it."""
        match = (
            (self.next_states[state, action] == next_state)
            & (self.rewards[state, action] == reward)
            & (self.terminals[state, action] == terminal)
        )
        slots = np.flatnonzero(match)
        if len(slots) == 0:
            self.unexplained += 1
            return False
        self.visits[state, action] += 1
        if self.pooling == "state_action":
            self.alpha[state, action, self.atoms[state, action, slots[0]]] += 1.0
        else:
            weights = self.alpha[slots]
            self.alpha[slots] += weights / weights.sum()
        return True

    def slot_alpha(self) -> np.ndarray:
        """``[S, A, K]`` concentration per slot."""
        return np.broadcast_to(self.alpha, self.next_states.shape)

    def atom_alpha(self) -> np.ndarray:
        """``[S, A, K]`` concentration per atom, held at the atom's leader slot (0 elsewhere)."""
        return aggregate(self.slot_alpha(), self.atoms)

    def mean(self) -> np.ndarray:
        """``[S, A, K]`` the posterior-mean kernel over slots (rows sum to 1)."""
        alpha = self.slot_alpha()
        return alpha / alpha.sum(axis=2, keepdims=True)

    def epistemic(self) -> np.ndarray:
        """``[S, A]`` sum of posterior variances over each (s, a)'s atoms."""
        return epistemic(self.atom_alpha())

    def aleatoric(self) -> np.ndarray:
        """``[S, A]`` entropy of the posterior-mean kernel over each (s, a)'s atoms."""
        return entropy(aggregate(self.mean(), self.atoms))
