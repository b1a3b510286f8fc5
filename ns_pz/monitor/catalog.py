"""Monitors by name, for experiment specs and command lines.

======================  ==================================================================
name                    monitor
======================  ==================================================================
``oracle``              :class:`~ns_pz.monitor.OracleMonitor`: every true change, exactly
``noisy_oracle``        :class:`~ns_pz.monitor.NoisyOracleMonitor`: misses, false alarms, delay
``cusum``               :class:`~ns_pz.monitor.TabularCusumMonitor`: tabular families
``prediction_error``    :class:`~ns_pz.monitor.PredictionErrorMonitor`: continuous families
======================  ==================================================================
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from typing import Any

from ns_pz.monitor.cusum import TabularCusumMonitor
from ns_pz.monitor.drift import PredictionErrorMonitor
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.noisy import NoisyOracleMonitor

MONITORS: dict[str, Callable[..., Monitor]] = {
    "oracle": OracleMonitor,
    "noisy_oracle": NoisyOracleMonitor,
    "cusum": TabularCusumMonitor,
    "prediction_error": PredictionErrorMonitor,
}


def make_monitor(name: str, params: Mapping[str, Any] | None = None) -> Monitor:
    """A fresh monitor of catalog ``name`` with keyword ``params``.

    Raises:
        ValueError: An unknown name, an unknown parameter, or a value the monitor refuses.
        TypeError: A value of the wrong type.
    """
    if name not in MONITORS:
        raise ValueError(f"monitor {name!r} is not known; known: {', '.join(MONITORS)}")
    factory = MONITORS[name]
    params = dict(params or {})
    allowed = [p for p in inspect.signature(factory).parameters if p != "self"]
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ValueError(
            f"monitor {name!r} has no parameter {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(allowed) or 'none'}"
        )
    return factory(**params)
