"""Reports: sensible precision, the best entry marked, tables that fit, figures that read."""

from __future__ import annotations

from pathlib import Path

import pytest

from ns_pz.cli import main
from ns_pz.experiments.report import Summary, auto_digits, table


def rows(values: dict[tuple[str, str], list[float]]) -> list[dict]:
    """Result rows: ``{(agent, "setting level"): returns}``."""
    out = []
    for (agent, column), returns in values.items():
        setting, level = column.split()
        for seed, value in enumerate(returns):
            out.append(
                {
                    "trial": f"{column}-{agent}-{seed}",
                    "agent": agent,
                    "setting": setting,
                    "notification": level,
                    "return": value,
                    "status": "ok",
                }
            )
    return out


def summaries(*errors: float, mean: float = 1.0) -> list[Summary]:
    """Summaries with these standard errors (10 episodes each)."""
    return [Summary(mean, error, 10, 0) for error in errors]


def test_digits_follow_the_standard_errors() -> None:
    """About two significant digits of the standard error, between 0 and 3 decimals."""
    assert auto_digits(summaries(0.04, 0.05)) == 3  # FrozenLake success rates
    assert auto_digits(summaries(0.4, 2.5, 3.1)) == 1  # CliffWalking, Bridge
    assert auto_digits(summaries(12.0, 30.0)) == 0  # CartPole
    assert auto_digits(summaries(0.0, 0.0, mean=-13.0)) == 1  # deterministic, large returns
    assert auto_digits(summaries(0.0, mean=0.5)) == 3


def test_cliffwalking_returns_print_at_one_decimal_and_the_best_is_bold() -> None:
    """CliffWalking-sized returns get one decimal; each column's best mean is bold (ties too)."""
    data = {
        ("random", "p=1 WN"): [-100.0, -120.0, -90.0, -95.0],
        ("MCTS", "p=1 WN"): [-13.0, -23.0, -13.0, -31.0],
        ("random", "p=1 WON"): [-100.0, -104.0],
        ("MCTS", "p=1 WON"): [-100.0, -104.0],
    }
    text = table(rows(data), "cliff")
    assert "| MCTS | **-20.0 ± 4.4** | **-102.0 ± 2.0** |" in text
    assert "| random | -101.2 ± 6.6 | **-102.0 ± 2.0** |" in text  # a tie: both bold
    assert "Bold: the best mean in its column." in text
    latex = table(rows(data), "cliff", "latex")
    assert r"\textbf{-20.0 $\pm$ 4.4}" in latex and "**" not in latex


def test_a_wide_table_splits_into_parts_that_fit() -> None:
    """With a width, a ten-column table becomes parts whose lines fit, each column once."""
    data = {(agent, f"s{i}=0.5 WN"): [1.0, 2.0] for agent in ("a", "b") for i in range(10)}
    wide = table(rows(data), "wide")
    assert max(len(line) for line in wide.splitlines() if line.startswith("|")) > 80
    narrow = table(rows(data), "wide", width=80)
    assert all(len(line) <= 80 for line in narrow.splitlines() if line.startswith("|"))
    assert "(columns, part 1 of " in narrow
    for i in range(10):  # every column still there, once
        assert narrow.count(f"s{i}=0.5 WN") == 1
    with pytest.raises(ValueError, match="width=5 must be an integer >= 20"):
        table(rows(data), "wide", width=5)


def test_eleven_agents_get_eleven_colours() -> None:
    """The paper's eleven agents get eleven distinct colours (matplotlib's cycle has ten)."""
    pytest.importorskip("matplotlib")
    from ns_pz.experiments.report import agent_colours

    colours = agent_colours(11)
    assert len(set(colours)) == 11
    with pytest.raises(ValueError, match="21 agents"):
        agent_colours(21)


def test_plot_writes_the_format_and_size_asked_into_out(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """SVG at the size asked; distinct bar colours; legend beside the bars; a grid of panels."""
    pytest.importorskip("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ns_pz.experiments.report import plot

    data = {
        (f"agent{i}", f"p={p} {level}"): [float(i), i + 1.0]
        for i in range(11)
        for p in (0.4, 0.6, 0.8)
        for level in ("WN", "WON")
    }
    saved: list[tuple[Figure, str]] = []
    original = Figure.savefig

    def keep(self: Figure, path: object, **kwargs: object) -> None:
        saved.append((self, str(path)))
        original(self, path, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    paths = plot(rows(data), "t", tmp_path / "figs", fmt="svg", figsize=(9.0, 5.0))
    assert [p.name for p in paths] == ["means.svg", "returns.svg"]
    assert all(p.read_text().lstrip().startswith("<?xml") for p in paths)
    means, returns = saved[0][0], saved[1][0]
    assert tuple(means.get_size_inches()) == (9.0, 5.0)
    bars = means.axes[0]
    colours = {tuple(patch.get_facecolor()) for patch in bars.patches}
    assert len(colours) == 11  # no colour repeats
    legend = bars.get_legend()
    renderer = FigureCanvasAgg(means).get_renderer()  # the figure was closed: a canvas again
    box = legend.get_window_extent(renderer)
    axes_box = bars.get_window_extent(renderer)
    assert box.x0 >= axes_box.x1  # the legend is beside the bars, not over them
    panels = [ax for ax in returns.axes if ax.get_visible()]
    assert len(panels) == 6 and {ax.get_subplotspec().get_geometry()[:2] for ax in panels} == {
        (2, 3)
    }  # 6 cells: two rows of three
    with pytest.raises(ValueError, match="fmt='gif'"):
        plot(rows(data), "t", tmp_path, fmt="gif")


def test_bench_plot_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``bench plot --out --format --figsize --dpi``; a bad size exits 2; a re-run offers table."""
    pytest.importorskip("matplotlib")
    spec = tmp_path / "tiny.toml"
    spec.write_text(
        'version = 1\nname = "tiny"\ntitle = "tiny"\nenv = "ns_pz/FrozenLake-v0"\n'
        'params = { slip = 0.7 }\nnotifications = ["detailed"]\n'
        '[change]\nkind = "single"\nparam = "slip"\nfirst_step = 1\nto = [0.4]\n'
        "[sizes.quick]\nepisodes = 2\nhorizon = 10\n[sizes.full]\nepisodes = 2\nhorizon = 10\n"
        '[[agents]]\nname = "random"\n'
    )
    lines: list[str] = []
    argv = ["bench", "run", str(spec), "--out", str(tmp_path / "o"), "--workers", "1"]
    assert main(argv, lines.append) == 0
    argv = ["bench", "plot", str(tmp_path / "o"), "--out", str(tmp_path / "f"), "--format", "pdf"]
    assert main([*argv, "--figsize", "8x3", "--dpi", "80"], lines.append) == 0
    assert (tmp_path / "f" / "means.pdf").read_bytes().startswith(b"%PDF")
    assert main([*argv, "--figsize", "8by3"], lines.append) == 2
    again: list[str] = []
    argv = ["bench", "run", str(spec), "--out", str(tmp_path / "o"), "--workers", "1"]
    capsys.readouterr()
    assert main(argv, again.append) == 2  # already there: says how to see the tables
    assert f"its tables again: ns-pz bench table {tmp_path / 'o' / 'tiny-quick'}" in (
        capsys.readouterr().err
    )
