"""Reports of a results directory: the paper's tables (Markdown, LaTeX) and figures (PNG).

A table has one row per agent and one column per cell (setting × notification, ``WN`` = with
detailed notification, ``WON`` = without); each entry is the mean episode return ± its standard
error (ddof=1) over the cell's episodes. Where the exact optimum of a cell is known (tabular
envs: finite-horizon value iteration knowing the schedule), an ``optimum`` row gives it and a
second table gives each agent's regret to it (optimum − mean). Every table and figure says what
its notification labels mean, that ± is one standard error, and over how many episodes
(:func:`legend`); the figures draw the optimum where it is known.

Where a detector ran (the ``WD`` columns), a detection table gives, per agent and detector
column, the mean detection delay, the false alarms per 1,000 steps and the missed changes, as
:func:`ns_pz.monitor.detection_metrics` scores the trials' change and alarm times.
"""

from __future__ import annotations

import json
import math
import re
import statistics
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ns_pz.agents.evaluation import mean_and_standard_error
from ns_pz.experiments.spec import DETECTOR, LEVEL_LABELS
from ns_pz.monitor.scoring import DetectionSummary, detection_metrics

#: ``optimum(setting, notification) -> value or None``.
Optimum = Callable[[str, str], float | None]

LEVEL_MEANINGS = {
    "WN": "with notification (told what changed; plans with the current θ)",
    "WON": "without notification (no flags; plans with θ_0)",
    "basic": "changed flags only (plans with θ_0)",
    "WD": "with a change detector (told what it detects, which may be late or wrong)",
}
"""What each notification label in a column name stands for."""


@dataclass(frozen=True)
class Summary:
    """One table entry."""

    mean: float
    error: float
    episodes: int
    failed: int


def summarise(
    rows: Sequence[Mapping[str, Any]], spec: Mapping[str, Any] | None = None
) -> tuple[list[str], list[str], dict[tuple[str, str], Summary]]:
    """Group rows by agent and cell.

    Args:
        rows: Result rows.
        spec: The run's spec record (``spec.json``'s ``spec``): orders agents and columns as
            the spec lists them; without it, they come in order of appearance.

    Returns:
        ``(agents, columns, summaries)``: agent labels, ``"setting notification"`` columns,
        and the summary of each (agent, column) that has at least one row.
    """
    agents: list[str] = []
    columns: list[str] = []
    if spec is not None:
        agents = [a["label"] for a in spec["agents"]]
        columns = [
            f"{setting} {LEVEL_LABELS[level]}"
            for setting in spec["settings"]
            for level in spec["notifications"]
        ]
    returns: dict[tuple[str, str], list[float]] = {}
    failures: dict[tuple[str, str], int] = {}
    for row in sorted(rows, key=lambda r: r["trial"]):
        column = f"{row['setting']} {row['notification']}"
        if row["agent"] not in agents:
            agents.append(row["agent"])
        if column not in columns:
            columns.append(column)
        key = (row["agent"], column)
        returns.setdefault(key, [])
        failures.setdefault(key, 0)
        if row["status"] == "ok":
            returns[key].append(float(row["return"]))
        else:
            failures[key] += 1
    summaries = {}
    for key, values in returns.items():
        if values:
            mean, error = mean_and_standard_error(values)
            summaries[key] = Summary(mean, error, len(values), failures[key])
        else:
            summaries[key] = Summary(float("nan"), float("nan"), 0, failures[key])
    return agents, columns, summaries


def table(
    rows: Sequence[Mapping[str, Any]],
    title: str,
    fmt: str = "markdown",
    optimum: Optimum | None = None,
    spec: Mapping[str, Any] | None = None,
    digits: int | None = None,
    width: int | None = None,
) -> str:
    """The results table (and, with ``optimum``, the regret table) as Markdown or LaTeX.

    In each column the best mean return is set in bold (every agent within rounding of it).

    Args:
        rows: Result rows.
        title: The tables' title.
        fmt: ``"markdown"`` or ``"latex"``.
        optimum: The exact optimum of a cell, where known.
        spec: The run's spec record; it fixes the order of agents and columns.
        digits: Decimals of every number; ``None``: from the data (:func:`auto_digits`).
        width: Markdown only: the most characters a line may take; a wider table is split
            into several, each with the agent column and as many cells as fit. ``None``: one
            table, however wide.

    Raises:
        ValueError: An unknown ``fmt``, or ``digits`` or ``width`` out of range.
    """
    if fmt not in ("markdown", "latex"):
        raise ValueError(f"fmt={fmt!r}; allowed: 'markdown', 'latex'")
    if digits is not None and (isinstance(digits, bool) or not 0 <= digits <= 12):
        raise ValueError(f"digits={digits!r} must be an integer in [0, 12] or None")
    if width is not None and (isinstance(width, bool) or width < 20):
        raise ValueError(f"width={width!r} must be an integer >= 20 or None")
    agents, columns, summaries = summarise(rows, spec)
    if digits is None:
        digits = auto_digits(summaries.values())
    optima = {}
    if optimum is not None:
        for column in columns:
            setting, notification = column.rsplit(" ", 1)
            optima[column] = optimum(setting, notification)
    best = _best(agents, columns, summaries, digits)
    body = []
    for agent in agents:
        body.append(
            [agent]
            + [_entry(summaries.get((agent, c)), digits, (agent, c) in best) for c in columns]
        )
    known = any(v is not None for v in optima.values())
    if known:
        body.append(["optimum"] + [_number(optima.get(c), digits) for c in columns])

    def render(title: str, header: list[str], body: list[list[str]], note: str) -> str:
        if fmt == "latex":
            return _latex(title, header, body, note)
        return _markdown(title, header, body, note, width)

    note = legend(columns, summaries) + " Bold: the best mean in its column."
    parts = [render(title, ["agent", *columns], body, note)]
    if known:
        regret = []
        for agent in agents:
            cells = []
            for column in columns:
                summary, best = summaries.get((agent, column)), optima.get(column)
                ok = summary is not None and summary.episodes and best is not None
                cells.append(
                    f"{best - summary.mean:.{digits}f}" if ok else "n/a"  # type: ignore[union-attr,operator]
                )
            regret.append([agent, *cells])
        note = "Regret = optimum − mean episode return; a negative regret is sampling noise."
        parts.append(render(f"{title}: regret to the optimum", ["agent", *columns], regret, note))
    detection = detection_summaries(rows)
    if detection:
        watched = [c for c in columns if any(k[1] == c for k in detection)]
        body = [
            [agent, *(_detection_entry(detection.get((agent, c)), digits) for c in watched)]
            for agent in agents
        ]
        heading = f"{title}: detection (mean delay in steps, false alarms per 1,000 steps, missed)"
        note = (
            "Per cell: mean delay of the changes found / false alarms per 1,000 steps / "
            "missed changes of all changes."
        )
        parts.append(render(heading, ["agent", *watched], body, note))
    return "\n\n".join(parts)


def detection_summaries(
    rows: Sequence[Mapping[str, Any]],
) -> dict[tuple[str, str], DetectionSummary]:
    """Detection scores of every (agent, column) whose detector ran (``WD`` columns).

    Rows without alarm times (failed trials, results written before they were recorded) are
    left out.
    """
    label = LEVEL_LABELS[DETECTOR]
    episodes: dict[tuple[str, str], list[tuple[list[int], list[int], int]]] = {}
    for row in sorted(rows, key=lambda r: r["trial"]):
        if row["notification"] != label or row["status"] != "ok" or not row.get("alarm_times"):
            continue
        key = (row["agent"], f"{row['setting']} {row['notification']}")
        episode = (
            json.loads(row["change_times"]),
            json.loads(row["alarm_times"]),
            int(row["length"]),
        )
        episodes.setdefault(key, []).append(episode)
    return {key: detection_metrics(value) for key, value in episodes.items()}


def _detection_entry(summary: DetectionSummary | None, digits: int) -> str:
    if summary is None:
        return "n/a"
    delay = "n/a" if summary.detected == 0 else f"{summary.mean_delay:.{min(digits, 1)}f}"
    return (
        f"{delay} / {summary.false_alarms_per_1000:.{min(digits, 1)}f} / "
        f"{summary.missed} of {summary.changes}"
    )


def legend(columns: Sequence[str], summaries: Mapping[tuple[str, str], Summary]) -> str:
    """One sentence for under a table or figure: the labels used, what ± is, and n.

    Args:
        columns: ``"setting notification"`` column names (as :func:`summarise` gives them).
        summaries: The entries; ``n`` is their episode count (failed trials left out), given as
            a range when it differs between entries.
    """
    meanings, n = _labels_and_count(columns, summaries)
    return f"{meanings}. Mean episode return ± one standard error, {n}."


def box_legend(columns: Sequence[str], summaries: Mapping[tuple[str, str], Summary]) -> str:
    """The caption of the returns figure: the labels used, what a box shows, and n."""
    meanings, n = _labels_and_count(columns, summaries)
    return (
        f"{meanings}. Box: quartiles of the episode returns, line: median, triangle: mean, "
        f"whiskers: 1.5 × the interquartile range, circles: returns beyond; {n}."
    )


def _labels_and_count(
    columns: Sequence[str], summaries: Mapping[tuple[str, str], Summary]
) -> tuple[str, str]:
    """What the columns' notification labels mean, and the episodes per cell."""
    labels = [label for label in LEVEL_MEANINGS if any(c.endswith(f" {label}") for c in columns)]
    counts = sorted({s.episodes for s in summaries.values() if s.episodes})
    if not counts:
        n = "no finished episodes"
    elif len(counts) == 1:
        n = f"n = {counts[0]} episodes per cell"
    else:
        n = f"n = {counts[0]}–{counts[-1]} episodes per cell (failed trials left out)"
    return "; ".join(f"{label} = {LEVEL_MEANINGS[label]}" for label in labels), n


def auto_digits(summaries: Iterable[Summary]) -> int:
    """Decimals that show the standard errors to about two significant digits, 0 to 3.

    FrozenLake's success rates (errors of a few hundredths) get 3; CliffWalking's and the
    Bridge's returns (errors of a few units, or 0 where every episode returns the same) 1;
    CartPole's (errors of tens) 0. Entries with a zero error are read by their mean's size.
    """
    errors = [s.error for s in summaries if s.episodes and math.isfinite(s.error) and s.error]
    if errors:
        error = statistics.median(errors)
        return max(0, min(3, 1 - math.floor(math.log10(error))))
    means = [abs(s.mean) for s in summaries if s.episodes and math.isfinite(s.mean)]
    if not means or max(means) < 10:
        return 3
    return 1


def _best(
    agents: Sequence[str],
    columns: Sequence[str],
    summaries: Mapping[tuple[str, str], Summary],
    digits: int,
) -> set[tuple[str, str]]:
    """The (agent, column) entries whose mean, as printed, is the column's highest."""
    best: set[tuple[str, str]] = set()
    for column in columns:
        means = {
            agent: round(summary.mean, digits)
            for agent in agents
            if (summary := summaries.get((agent, column))) is not None and summary.episodes
        }
        if means:
            top = max(means.values())
            best.update((agent, column) for agent, mean in means.items() if mean == top)
    return best


def _entry(summary: Summary | None, digits: int, best: bool = False) -> str:
    if summary is None:
        return "n/a"
    if not summary.episodes:
        return f"failed ({summary.failed})"
    text = f"{summary.mean:.{digits}f} ± {summary.error:.{digits}f}"
    if best:
        text = f"**{text}**"
    if summary.failed:
        text += f" ({summary.failed} failed)"
    return text


def _number(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _markdown(
    title: str, header: list[str], body: list[list[str]], note: str, width: int | None = None
) -> str:
    """A Markdown table, split by columns into parts no line of which is wider than ``width``."""
    sizes = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]
    parts: list[list[int]] = [[]]
    used = 4 + sizes[0]  # "| agent |"
    for i in range(1, len(header)):
        if width is not None and parts[-1] and used + sizes[i] + 3 > width:
            parts.append([])
            used = 4 + sizes[0]
        parts[-1].append(i)
        used += sizes[i] + 3
    lines = [f"**{title}**"]
    for number, part in enumerate(parts, 1):
        if len(parts) > 1:
            lines += ["", f"(columns, part {number} of {len(parts)})"]
        shown = [0, *part]
        lines += ["", "| " + " | ".join(header[i] for i in shown) + " |"]
        lines.append("|" + "---|" * len(shown))
        lines += ["| " + " | ".join(row[i] for i in shown) + " |" for row in body]
    lines += ["", note]
    return "\n".join(lines)


def _latex(title: str, header: list[str], body: list[list[str]], note: str) -> str:
    def cell(text: str) -> str:
        # Symbols become placeholders first, so escaping cannot reach inside their math.
        symbols = (("θ_0", r"\theta_0"), ("±", r"\pm"), ("θ", r"\theta"), ("−", "-"))
        for i, (char, _) in enumerate(symbols):
            text = text.replace(char, f"\0{i}\0")
        for char, escaped in (("_", r"\_"), ("%", r"\%"), ("&", r"\&"), ("#", r"\#")):
            text = text.replace(char, escaped)
        for i, (_, symbol) in enumerate(symbols):
            text = text.replace(f"\0{i}\0", f"${symbol}$")
        return re.sub(r"\*\*(.+?)\*\*", r"\\textbf{\1}", text)  # the best entry

    lines = [
        r"\begin{table}[t]",
        r"\centering",
        rf"\caption{{{cell(title)}. {cell(note)}}}",
        r"\begin{tabular}{l" + "r" * (len(header) - 1) + "}",
        r"\toprule",
        " & ".join(cell(h) for h in header) + r" \\",
        r"\midrule",
    ]
    lines += [" & ".join(cell(c) for c in row) + r" \\" for row in body]
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines)


FIGURE_FORMATS = ("png", "pdf", "svg")


def agent_colours(count: int) -> list[Any]:
    """``count`` distinct colours: matplotlib's ``tab20`` dark shades, then its light ones.

    Its default cycle has ten colours, so an eleventh agent would repeat the first.

    Raises:
        ValueError: More than 20 agents.
    """
    import matplotlib

    if count > 20:
        raise ValueError(f"{count} agents; the figures tell at most 20 apart")
    palette = matplotlib.colormaps["tab20"].colors
    return [palette[(2 * i) % 20 + (2 * i) // 20] for i in range(count)]


def plot(
    rows: Sequence[Mapping[str, Any]],
    title: str,
    out_dir: str | Path,
    spec: Mapping[str, Any] | None = None,
    optimum: Optimum | None = None,
    fmt: str = "png",
    figsize: tuple[float, float] | None = None,
    dpi: int = 120,
) -> list[Path]:
    """Two figures: mean ± SE per agent and cell (``means``), and the returns' distributions.

    Both carry the :func:`legend` under the plot and, with ``optimum``, a dashed line at each
    cell's exact optimum; an agent has the same colour in both. Needs matplotlib
    (``pip install "ns_pz[plot]"``).

    Args:
        rows: Result rows.
        title: The figures' title.
        out_dir: Folder the figures go to (created if needed).
        spec: The run's spec record (orders agents and columns).
        optimum: The exact optimum of a cell, where known.
        fmt: ``"png"``, ``"pdf"`` or ``"svg"``.
        figsize: ``(width, height)`` in inches of each figure; ``None``: from the number of
            agents and cells.
        dpi: Resolution of a PNG.

    Raises:
        RuntimeError: matplotlib is not installed.
        ValueError: An unknown ``fmt``, a non-positive size or ``dpi``.
    """
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"fmt={fmt!r}; allowed: {FIGURE_FORMATS}")
    if figsize is not None and (len(figsize) != 2 or not min(figsize) > 0):
        raise ValueError(f"figsize={figsize!r} must be (width, height) in inches, both > 0")
    if isinstance(dpi, bool) or not isinstance(dpi, int) or dpi < 10:
        raise ValueError(f"dpi={dpi!r} must be an integer >= 10")
    try:  # figures of their own, not pyplot's: the caller's backend and figures are left alone
        from matplotlib.figure import Figure
    except ImportError:
        raise RuntimeError('plots need matplotlib: pip install "ns_pz[plot]"') from None
    agents, columns, summaries = summarise(rows, spec)
    optima = {}
    for column in columns if optimum is not None else []:
        value = optimum(*column.rsplit(" ", 1))  # type: ignore[misc]
        if value is not None:
            optima[column] = value
    colours = dict(zip(agents, agent_colours(len(agents)), strict=True))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig = _means_figure(Figure, agents, columns, summaries, optima, colours, figsize)
    fig.axes[0].set_title(title)
    _footnote(fig, legend(columns, summaries))
    means_path = out / f"means.{fmt}"
    fig.savefig(means_path, dpi=dpi)

    fig = _returns_figure(Figure, rows, agents, columns, optima, colours, figsize)
    fig.suptitle(f"{title}: return distributions")
    _footnote(fig, box_legend(columns, summaries))
    returns_path = out / f"returns.{fmt}"
    fig.savefig(returns_path, dpi=dpi)
    return [means_path, returns_path]


def _means_figure(
    figure: Any,
    agents: Sequence[str],
    columns: Sequence[str],
    summaries: Mapping[tuple[str, str], Summary],
    optima: Mapping[str, float],
    colours: Mapping[str, Any],
    figsize: tuple[float, float] | None,
) -> Any:
    """Grouped bars, one group per cell; the legend outside the axes, on the right."""
    width = 0.8 / max(len(agents), 1)
    size = figsize or (max(6.0, 1.4 * len(columns) + 3.5), 4.5)
    fig = figure(figsize=size)
    ax = fig.subplots()
    for i, agent in enumerate(agents):
        xs, means, errors = [], [], []
        for j, column in enumerate(columns):
            summary = summaries.get((agent, column))
            if summary is not None and summary.episodes:
                xs.append(j + (i - (len(agents) - 1) / 2) * width)
                means.append(summary.mean)
                errors.append(summary.error)
        ax.bar(xs, means, width, yerr=errors, capsize=2, label=agent, color=colours[agent])
    label = "exact optimum"  # in the legend once
    for j, column in enumerate(columns):
        if column in optima:
            ax.hlines(optima[column], j - 0.45, j + 0.45, "black", "--", label=label, gid="optimum")
            label = "_nolegend_"
    ax.set_xticks(range(len(columns)), columns, rotation=20, ha="right")
    ax.set_ylabel("episode return (mean ± 1 SE)")
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def _returns_figure(
    figure: Any,
    rows: Sequence[Mapping[str, Any]],
    agents: Sequence[str],
    columns: Sequence[str],
    optima: Mapping[str, float],
    colours: Mapping[str, Any],
    figsize: tuple[float, float] | None,
) -> Any:
    """One horizontal box plot per cell, at most three cells a row; agents named on the left."""
    per_row = min(3, max(len(columns), 1))
    grid_rows = math.ceil(len(columns) / per_row) if columns else 1
    size = figsize or (4.2 * per_row + 1.5, (0.28 * len(agents) + 1.2) * grid_rows + 0.8)
    fig = figure(figsize=size)
    axes = fig.subplots(grid_rows, per_row, squeeze=False, sharey=True)
    for index, column in enumerate(columns):
        ax = axes[index // per_row][index % per_row]
        data = [
            [
                float(r["return"])
                for r in rows
                if r["status"] == "ok"
                and r["agent"] == agent
                and f"{r['setting']} {r['notification']}" == column
            ]
            for agent in agents
        ]
        boxes = ax.boxplot(
            data, orientation="horizontal", showmeans=True, patch_artist=True, widths=0.6
        )
        for box, agent in zip(boxes["boxes"], agents, strict=True):
            box.set(facecolor=colours[agent], alpha=0.7)
        ax.set_yticks(range(1, len(agents) + 1), agents, fontsize="small")
        ax.invert_yaxis()  # the first agent on top, as in the tables
        if column in optima:
            ax.axvline(
                optima[column], color="black", linestyle="--", label="exact optimum", gid="optimum"
            )
        ax.set_title(column, fontsize="small")
        ax.tick_params(axis="x", labelsize="small")
        if index // per_row == grid_rows - 1 or index + per_row >= len(columns):
            ax.set_xlabel("episode return", fontsize="small")
    for index in range(len(columns), grid_rows * per_row):
        axes[index // per_row][index % per_row].set_visible(False)
    if optima:
        fig.axes[0].legend(fontsize="small", loc="lower right")
    return fig


def _footnote(fig: Any, text: str) -> None:
    """Lay out ``fig`` with ``text`` wrapped under the axes."""
    import textwrap

    width = max(60, int(fig.get_figwidth() * 14))
    wrapped = textwrap.fill(text, width)
    lines = wrapped.count("\n") + 1
    bottom = min(0.4, 0.04 + 0.045 * lines * 4 / fig.get_figheight())
    fig.tight_layout(rect=(0, bottom, 1, 1))
    fig.text(0.01, 0.01, wrapped, fontsize="x-small", va="bottom", ha="left")
