"""The figure of a robustness report (matplotlib, the ``plot`` extra)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ns_pz.learning.robustness import RobustnessReport


def plot_report(report: RobustnessReport, path: str | None = None) -> Any:
    """A bar per summary row and, for a 2-parameter product grid, a heatmap of its means.

    Each bar is a row's mean with its interval; a dot marks the row's CVaR.

    Raises:
        ImportError: matplotlib is missing; the message names the ``plot`` extra.
    """
    try:  # a figure of its own, not pyplot's: the caller's backend and figures are left alone
        from matplotlib.figure import Figure
    except ImportError as error:  # pragma: no cover - depends on the install
        raise ImportError(
            "RobustnessReport.plot needs matplotlib: pip install 'ns_pz[plot]'"
        ) from error
    heat = _heatmap_axes(report)
    figure = Figure(figsize=(11 if heat else 6, 4))
    axes = figure.subplots(1, 2 if heat else 1, squeeze=False)
    bars = axes[0][0]
    labels = [row.label for row in report.rows]
    means = np.array([row.mean.value for row in report.rows])
    errors = np.array(
        [
            [row.mean.value - row.mean.low for row in report.rows],
            [row.mean.high - row.mean.value for row in report.rows],
        ]
    )
    positions = np.arange(len(labels))
    bars.bar(positions, means, yerr=errors, capsize=3, color="#4C72B0", label="mean")
    bars.plot(
        positions,
        [row.cvar.value for row in report.rows],
        "o",
        color="#C44E52",
        label=f"CVaR {report.alpha:g}",
    )
    bars.set_xticks(positions, labels, rotation=30, ha="right")
    bars.set_ylabel("episode return")
    bars.set_title(f"{report.env_id}: {len(report.seeds)} episodes per condition")
    bars.legend(loc="best", fontsize="small")
    if heat:
        names, xs, ys, values = heat
        image = axes[0][1].imshow(values, origin="lower", aspect="auto", cmap="viridis")
        axes[0][1].set_xticks(range(len(xs)), [f"{x:.3g}" for x in xs])
        axes[0][1].set_yticks(range(len(ys)), [f"{y:.3g}" for y in ys])
        axes[0][1].set_xlabel(names[0])
        axes[0][1].set_ylabel(names[1])
        axes[0][1].set_title("mean return over the grid")
        figure.colorbar(image, ax=axes[0][1])
    figure.tight_layout()
    if path is not None:
        figure.savefig(path, dpi=120)
    return figure


def _heatmap_axes(report: RobustnessReport) -> Any:
    """(names, x values, y values, means[y, x]) of a full 2-parameter product grid, else None."""
    grid = [c for c in report.conditions if c.group == "grid" and c.params is not None]
    if not grid:
        return None
    names = list(grid[0].params or {})
    if len(names) != 2 or any(list(c.params or {}) != names for c in grid):
        return None
    if any(np.ndim(v) for c in grid for v in (c.params or {}).values()):
        return None
    xs = sorted({float(c.params[names[0]]) for c in grid})  # type: ignore[index]
    ys = sorted({float(c.params[names[1]]) for c in grid})  # type: ignore[index]
    if len(xs) * len(ys) != len(grid):
        return None
    values = np.full((len(ys), len(xs)), np.nan)
    for c in grid:
        params = c.params or {}
        values[ys.index(float(params[names[1]])), xs.index(float(params[names[0]]))] = c.mean
    return names, xs, ys, values
