"""What a network sees of a state, and a numpy forward pass of a trained MLP.

Networks take the base environment's observation: a one-hot vector for a ``Discrete``
observation space (the grid worlds), the raw vector for a ``Box`` (CartPole's 4 floats). Trained
weights are plain arrays, so acting with a trained network needs numpy only (no torch in the
workers that play the trials; a forward pass of these small MLPs takes a few microseconds).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from ns_pz.agents.learning.mlp import forward


def feature_size(space: spaces.Space[Any]) -> int:
    """Length of the feature vector of an observation of ``space``.

    Raises:
        TypeError: ``space`` is neither ``Discrete`` nor a ``Box``.
    """
    if isinstance(space, spaces.Discrete):
        return int(space.n)
    if isinstance(space, spaces.Box):
        return int(np.prod(space.shape))
    raise TypeError(f"observation space {space!r} must be Discrete or Box for a network input")


def features(space: spaces.Space[Any], observation: Any) -> np.ndarray:
    """``[feature_size(space)]`` float32 input of one observation (one-hot for ``Discrete``)."""
    if isinstance(space, spaces.Discrete):
        out = np.zeros(int(space.n), dtype=np.float32)
        out[int(observation) - int(space.start)] = 1.0
        return out
    return np.asarray(observation, dtype=np.float32).reshape(-1)


class NumpyMLP:
    """A ReLU MLP from exported weights: ``prefix.0.weight``, ``prefix.0.bias``, ``prefix.1...``.

    Layer ``i`` computes ``x @ weight.T + bias`` (torch's ``Linear`` layout), with ReLU between
    layers and none after the last.

    Raises:
        ValueError: ``weights`` has no layer under ``prefix`` or mismatched shapes.
    """

    def __init__(self, weights: Mapping[str, np.ndarray], prefix: str) -> None:
        self.layers: list[tuple[np.ndarray, np.ndarray]] = []
        while f"{prefix}.{len(self.layers)}.weight" in weights:
            i = len(self.layers)
            w = np.asarray(weights[f"{prefix}.{i}.weight"], dtype=np.float64)
            b = np.asarray(weights[f"{prefix}.{i}.bias"], dtype=np.float64)
            chained = w.ndim == 2 and (not self.layers or w.shape[1] == self.layers[-1][0].shape[1])
            if not chained or b.shape != w.shape[:1]:
                raise ValueError(f"layer {prefix}.{i} has mismatched shapes {w.shape}, {b.shape}")
            self.layers.append((w.T.copy(), b))
        if not self.layers:
            raise ValueError(f"weights have no layer {prefix}.0 (keys: {sorted(weights)})")

    @property
    def input_size(self) -> int:
        """Length of the input vector."""
        return int(self.layers[0][0].shape[0])

    @property
    def output_size(self) -> int:
        """Length of the output vector."""
        return int(self.layers[-1][0].shape[1])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Outputs for ``x`` (``[input_size]`` or ``[batch, input_size]``)."""
        return forward(self.layers, np.asarray(x, dtype=np.float64))
