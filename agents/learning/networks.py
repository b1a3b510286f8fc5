"""The torch networks the learners train, and their export to plain arrays (imports torch).

Layouts follow NS-Gym's trained models: a ReLU MLP whose ``hidden``
tuple lists the widths of the hidden layers, so a DQN with ``hidden=(64,)`` has two ``Linear``
layers (NS-Gym's "2 layers, 64 units"). Exported names match :class:`NumpyMLP`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """Run the block on one torch thread, restoring the caller's thread count afterwards."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


@contextlib.contextmanager
def seeded_torch(seed: int) -> Iterator[None]:
    """Run the block on one thread with torch's generator seeded, restoring both afterwards.

    Network initialisation and anything else drawn from torch's global generator inside the
    block depends on ``seed`` only, and the caller's generator state is left as it was.
    """
    with one_thread(), torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        yield


def mlp(inputs: int, hidden: Sequence[int], outputs: int) -> nn.Sequential:
    """``Linear`` layers ``inputs -> hidden... -> outputs`` with ReLU between them."""
    widths = [inputs, *hidden, outputs]
    layers: list[nn.Module] = []
    for i in range(len(widths) - 1):
        layers.append(nn.Linear(widths[i], widths[i + 1]))
        if i < len(widths) - 2:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class LayerCalls:
    """An :func:`mlp` network's forward pass as plain ``F.linear`` and ``relu`` calls.

    Calling it computes what calling ``network`` computes, bit for bit and with the same
    autograd graph: ``nn.Linear`` and ``nn.ReLU`` make exactly these calls on exactly these
    parameter tensors. It skips ``nn.Module``'s dispatch (hooks, ``__getattr__``, the
    ``Sequential`` loop), which on these small networks costs more than the arithmetic (a
    4-64-2 forward of one state: about 28 µs through the module, 15 µs here). The parameters
    are shared, not copied: an optimiser step or ``network.load_state_dict`` shows at once.

    Args:
        network: ``Linear`` layers with a ``ReLU`` between each two (:func:`mlp`'s layout).
        detached: Hold detached views of the parameters (the same storage), for forward passes
            that need no gradient: nothing is recorded for autograd even outside
            ``torch.no_grad()``.

    Raises:
        TypeError: ``network`` is not laid out as :func:`mlp` makes it.
    """

    def __init__(self, network: nn.Sequential, detached: bool = False) -> None:
        modules = list(network)
        linear = modules[::2]
        layout = all(isinstance(m, nn.Linear) for m in linear) and all(
            type(m) is nn.ReLU and not m.inplace for m in modules[1::2]
        )
        if not modules or len(modules) % 2 != 1 or not layout:
            raise TypeError(
                f"network={network!r} must be Linear layers with a ReLU between each two"
            )
        self.layers = [(m.weight, m.bias) for m in linear]
        if detached:
            self.layers = [(w.detach(), b.detach()) for w, b in self.layers]
        self._parameters = [tensor for layer in self.layers for tensor in layer]

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        """``network(x)``: ``[..., outputs]`` of ``[..., inputs]``."""
        last = len(self.layers) - 1
        for i, (weight, bias) in enumerate(self.layers):
            x = F.linear(x, weight, bias)
            if i < last:
                x = torch.relu(x)
        return x

    def parameters(self) -> Iterator[torch.Tensor]:
        """The parameters in ``network.parameters()``'s order (weight, bias, layer by layer)."""
        return iter(self._parameters)


def export(network: nn.Sequential, prefix: str) -> dict[str, np.ndarray]:
    """The ``Linear`` layers of ``network`` as ``{prefix.i.weight, prefix.i.bias}`` arrays."""
    linears = [m for m in network if isinstance(m, nn.Linear)]
    out: dict[str, np.ndarray] = {}
    for i, layer in enumerate(linears):
        out[f"{prefix}.{i}.weight"] = layer.weight.detach().cpu().numpy().copy()
        out[f"{prefix}.{i}.bias"] = layer.bias.detach().cpu().numpy().copy()
    return out


class PolicyValueNet(nn.Module):
    """AlphaZero's network: a shared ReLU trunk, policy logits and a scalar value.

    Args:
        inputs: Feature size.
        hidden: Widths of the trunk's layers (the paper's "3 layers, 64 units": ``(64,) * 3``).
        num_actions: Policy outputs.
    """

    def __init__(self, inputs: int, hidden: Sequence[int], num_actions: int) -> None:
        super().__init__()
        if not hidden:
            raise ValueError(f"hidden={tuple(hidden)!r} must list at least one layer width")
        self.trunk = mlp(inputs, hidden[:-1], hidden[-1])
        self.policy = nn.Linear(hidden[-1], num_actions)
        self.value = nn.Linear(hidden[-1], 1)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(policy logits [batch, num_actions], value [batch])``."""
        h = torch.relu(self.trunk(x))
        return self.policy(h), self.value(h).squeeze(-1)

    def export(self) -> dict[str, np.ndarray]:
        """Trunk, policy head and value head as arrays (see :class:`PolicyValueMLP`)."""
        heads = {
            "policy.0.weight": self.policy.weight,
            "policy.0.bias": self.policy.bias,
            "value.0.weight": self.value.weight,
            "value.0.bias": self.value.bias,
        }
        out = export(self.trunk, "trunk")
        out.update({k: v.detach().cpu().numpy().copy() for k, v in heads.items()})
        return out
