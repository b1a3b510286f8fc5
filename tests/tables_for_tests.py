"""Hand-written outcome tables shared by the search tests."""

from __future__ import annotations

import numpy as np

from ns_pz.planning import TabularOutcomes


def table(rows: list[list[list[tuple[float, int, float, bool]]]]) -> TabularOutcomes:
    """An outcome table from ``rows[s][a] = [(prob, next, reward, terminal), ...]``."""
    probs, nxt, rew, term = (
        np.array([[[o[i] for o in row] for row in by_s] for by_s in rows]) for i in range(4)
    )
    return TabularOutcomes(
        probs.astype(float), nxt.astype(np.int64), rew.astype(float), term.astype(bool)
    )


def coin_table() -> TabularOutcomes:
    """Root 0: action 0 pays 0.6 and ends; action 1 pays 1 or 0 on a fair coin and ends."""
    ends = [(1.0, 1, 0.0, True), (0.0, 1, 0.0, True)]
    return table(
        [
            [
                [(1.0, 1, 0.6, True), (0.0, 1, 0.6, True)],
                [(0.5, 1, 1.0, True), (0.5, 1, 0.0, True)],
            ],
            [ends, ends],
        ]
    )
