"""A fixed-size replay buffer of feature vectors, sampled with the learner's own generator."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Batch:
    """A sample of transitions.

    ``features`` and ``next_features`` are ``[batch, n]``; ``terminated`` is 1.0 where the
    transition ended the episode (truncation is not termination).
    """

    features: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    next_features: np.ndarray
    terminated: np.ndarray


class ReplayBuffer:
    """The last ``capacity`` transitions; the oldest is overwritten first.

    Raises:
        ValueError: ``capacity`` or ``feature_size`` below 1.
    """

    def __init__(self, capacity: int, feature_size: int) -> None:
        if capacity < 1 or feature_size < 1:
            raise ValueError(
                f"capacity={capacity!r} and feature_size={feature_size!r} must be >= 1"
            )
        self.capacity = capacity
        self.features = np.zeros((capacity, feature_size), dtype=np.float32)
        self.next_features = np.zeros((capacity, feature_size), dtype=np.float32)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.terminated = np.zeros(capacity, dtype=np.float32)
        self.size = 0
        self._next = 0

    def add(
        self, x: np.ndarray, action: int, reward: float, next_x: np.ndarray, terminated: bool
    ) -> None:
        """Store one transition."""
        i = self._next
        self.features[i], self.actions[i], self.rewards[i] = x, action, reward
        self.next_features[i], self.terminated[i] = next_x, float(terminated)
        self._next = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    @property
    def next_row(self) -> int:
        """The row the next transition goes to."""
        return self._next

    def wrote(self, count: int) -> None:
        """Count ``count`` transitions written in place from :attr:`next_row` on (wrapping).

        Raises:
            ValueError: ``count`` is negative.
        """
        if count < 0:
            raise ValueError(f"count={count!r} must be >= 0")
        self._next = (self._next + count) % self.capacity
        self.size = min(self.size + count, self.capacity)

    def sample(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """``batch_size`` transitions drawn uniformly with replacement."""
        return self.batch(self.sample_index(batch_size, rng))

    def sample_index(self, batch_size: int, rng: np.random.Generator) -> np.ndarray:
        """The rows :meth:`sample` would take: ``batch_size`` drawn uniformly with replacement."""
        return rng.integers(self.size, size=batch_size)

    def batch(self, index: np.ndarray) -> Batch:
        """The transitions in rows ``index``."""
        return Batch(
            self.features[index],
            self.actions[index],
            self.rewards[index],
            self.next_features[index],
            self.terminated[index],
        )
