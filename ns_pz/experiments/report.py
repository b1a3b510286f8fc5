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
from collections.abc import Callable, Mapping, Sequence
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
    digits: int = 3,
) -> str:
    """The results table (and, with ``optimum``, the regret table) as Markdown or LaTeX.

    ``spec`` (the run's spec record) fixes the order of agents and columns.

    Raises:
        ValueError: An unknown ``fmt``.
    """
    if fmt not in ("markdown", "latex"):
        raise ValueError(f"fmt={fmt!r}; allowed: 'markdown', 'latex'")
    agents, columns, summaries = summarise(rows, spec)
    optima = {}
    if optimum is not None:
        for column in columns:
            setting, notification = column.rsplit(" ", 1)
            optima[column] = optimum(setting, notification)
    body = []
    for agent in agents:
        body.append([agent] + [_entry(summaries.get((agent, c)), digits) for c in columns])
    known = any(v is not None for v in optima.values())
    if known:
        body.append(["optimum"] + [_number(optima.get(c), digits) for c in columns])
    render = _markdown if fmt == "markdown" else _latex
    note = legend(columns, summaries)
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
    labels = [label for label in LEVEL_MEANINGS if any(c.endswith(f" {label}") for c in columns)]
    counts = sorted({s.episodes for s in summaries.values() if s.episodes})
    if not counts:
        n = "no finished episodes"
    elif len(counts) == 1:
        n = f"n = {counts[0]} episodes per cell"
    else:
        n = f"n = {counts[0]}–{counts[-1]} episodes per cell (failed trials left out)"
    meanings = "; ".join(f"{label} = {LEVEL_MEANINGS[label]}" for label in labels)
    return f"{meanings}. Mean episode return ± one standard error, {n}."


def _entry(summary: Summary | None, digits: int) -> str:
    if summary is None:
        return "n/a"
    if not summary.episodes:
        return f"failed ({summary.failed})"
    text = f"{summary.mean:.{digits}f} ± {summary.error:.{digits}f}"
    if summary.failed:
        text += f" ({summary.failed} failed)"
    return text


def _number(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _markdown(title: str, header: list[str], body: list[list[str]], note: str) -> str:
    lines = [f"**{title}**", "", "| " + " | ".join(header) + " |"]
    lines.append("|" + "---|" * len(header))
    lines += ["| " + " | ".join(row) + " |" for row in body]
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
        for i, (_, math) in enumerate(symbols):
            text = text.replace(f"\0{i}\0", f"${math}$")
        return text

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


def plot(
    rows: Sequence[Mapping[str, Any]],
    title: str,
    out_dir: str | Path,
    spec: Mapping[str, Any] | None = None,
    optimum: Optimum | None = None,
) -> list[Path]:
    """Two PNG figures: mean ± SE per agent and cell, and the distribution of returns.

    Both carry the :func:`legend` under the plot and, with ``optimum``, a dashed line at each
    cell's exact optimum. Needs matplotlib (``pip install "ns_pz[plot]"``).

    Raises:
        RuntimeError: matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise RuntimeError('plots need matplotlib: pip install "ns_pz[plot]"') from None
    agents, columns, summaries = summarise(rows, spec)
    optima = {}
    for column in columns if optimum is not None else []:
        value = optimum(*column.rsplit(" ", 1))  # type: ignore[misc]
        if value is not None:
            optima[column] = value
    note = legend(columns, summaries)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    width = 0.8 / max(len(agents), 1)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.4 * len(columns) + 2), 4))
    for i, agent in enumerate(agents):
        xs, means, errors = [], [], []
        for j, column in enumerate(columns):
            summary = summaries.get((agent, column))
            if summary is not None and summary.episodes:
                xs.append(j + (i - (len(agents) - 1) / 2) * width)
                means.append(summary.mean)
                errors.append(summary.error)
        ax.bar(xs, means, width, yerr=errors, capsize=3, label=agent)
    label = "exact optimum"  # in the legend once
    for j, column in enumerate(columns):
        if column in optima:
            ax.hlines(optima[column], j - 0.45, j + 0.45, "black", "--", label=label, gid="optimum")
            label = "_nolegend_"
    ax.set_xticks(range(len(columns)), columns, rotation=20, ha="right")
    ax.set_ylabel("episode return (mean ± 1 SE)")
    ax.set_title(title)
    ax.legend(fontsize="small")
    _footnote(fig, note)
    means_path = out / "means.png"
    fig.savefig(means_path, dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(
        1, len(columns), figsize=(max(6.0, 2.6 * len(columns)), 3.6), squeeze=False
    )
    for ax, column in zip(axes[0], columns, strict=True):
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
        ax.boxplot(data, tick_labels=agents, showmeans=True)
        if column in optima:
            ax.axhline(
                optima[column], color="black", linestyle="--", label="exact optimum", gid="optimum"
            )
        ax.set_title(column, fontsize="small")
        ax.tick_params(axis="x", labelrotation=45, labelsize="small")
    axes[0][0].set_ylabel("episode return")
    if optima:
        axes[0][0].legend(fontsize="small")
    fig.suptitle(f"{title}: return distributions")
    _footnote(fig, note)
    returns_path = out / "returns.png"
    fig.savefig(returns_path, dpi=120)
    plt.close(fig)
    return [means_path, returns_path]


def _footnote(fig: Any, text: str) -> None:
    """Lay out ``fig`` with ``text`` wrapped under the axes."""
    import textwrap

    width = max(60, int(fig.get_figwidth() * 14))
    wrapped = textwrap.fill(text, width)
    lines = wrapped.count("\n") + 1
    bottom = min(0.4, 0.04 + 0.045 * lines * 4 / fig.get_figheight())
    fig.tight_layout(rect=(0, bottom, 1, 1))
    fig.text(0.01, 0.01, wrapped, fontsize="x-small", va="bottom", ha="left")
