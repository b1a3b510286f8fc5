"""``bench estimate``: capped trial timing, training timed for seconds, what it says up front."""

from __future__ import annotations

import io
import os
from collections.abc import Callable
from pathlib import Path

import pytest
from specs_for_tests import MCTS, RANDOM, tiny_spec

from ns_pz import cli
from ns_pz.cli import main
from ns_pz.experiments import load_spec
from ns_pz.experiments.estimate import estimate, plan
from ns_pz.experiments.trials import expand

TINY = tiny_spec(RANDOM, MCTS, full_episodes=6)


def write_spec(folder: Path, text: str = TINY) -> Path:
    """Write the spec file and return its path."""
    path = folder / "tiny.toml"
    path.write_text(text)
    return path


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture(autouse=True)
def _nothing_played_yet(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts as a fresh process would: no agent has paid its one-off costs."""
    from ns_pz.experiments import estimate as module

    monkeypatch.setattr(module, "_PLAYED", set())


def test_estimate_times_every_cell_and_projects(tmp_path: Path) -> None:
    """One cost per agent × cell, projecting its full trial count; the CLI prints the total."""
    experiment = load_spec(write_spec(tmp_path), "full")
    costs = estimate(experiment, samples=1, cell_seconds=60.0)
    assert len(costs) == 2 * 2 * 2
    assert all(c.trials == 6 and c.seconds_per_trial > 0 for c in costs)
    assert all(0 < c.cpu_seconds_per_trial and c.total_cpu_seconds > 0 for c in costs)
    assert not any(c.at_horizon for c in costs)  # whole episodes, well within a minute
    lines: list[str] = []
    argv = ["bench", "estimate", str(write_spec(tmp_path)), "--samples", "1", "--workers", "2"]
    assert main(argv, lines.append) == 0
    assert lines[0].startswith("estimate: 0 network(s) to train")
    assert "8 agent x cell group(s), up to 1 seed(s) each within 1 s per group" in lines[0]
    assert lines[-3].startswith("projected (specs one after the other; a worker starts in ")
    assert lines[-2].startswith("  on 2 worker(s), idle cores (from CPU time): no network")
    assert "48 trials" in lines[-2] and "wall " in lines[-2]
    assert lines[-1].startswith(f"  on this machine ({os.cpu_count()} cores) at its present load")
    with pytest.raises(ValueError, match="samples=0 must be >= 1"):
        estimate(experiment, samples=0)
    with pytest.raises(ValueError, match="cell_seconds=0 must be >= 0.001"):
        estimate(experiment, cell_seconds=0)


def test_an_episode_over_the_cap_is_cut_and_projected_to_the_horizon(tmp_path: Path) -> None:
    """A cell's timing stops at its cap; the time per step is projected to the horizon.

    5,000 iterations a step take several milliseconds, past the five caps of 1 ms after which an
    episode is cut however few steps it played; the first step from FrozenLake's start never
    ends the episode, so every MCTS episode is cut, on a quiet machine or a busy one.
    """
    slow = MCTS.replace("iterations = 200", "iterations = 5000")
    experiment = load_spec(write_spec(tmp_path, tiny_spec(RANDOM, slow, full_episodes=6)), "full")
    costs = estimate(experiment, samples=2, cell_seconds=0.001)
    mcts = [c for c in costs if c.agent == "MCTS"]
    assert mcts and all(c.at_horizon for c in mcts)
    whole = estimate(experiment, samples=1, cell_seconds=60.0)
    for cut, played in zip(costs, whole, strict=True):
        if cut.agent == "MCTS":  # the horizon bounds the played episode from above
            assert cut.seconds_per_trial > 0.5 * played.seconds_per_trial


def test_plan_says_what_it_will_do_and_how_long(tmp_path: Path) -> None:
    """The plan counts groups and networks and bounds the time before anything runs."""
    experiment = load_spec(write_spec(tmp_path), "full")
    what = plan([experiment], samples=2, cell_seconds=1.5, probe_seconds=4.0)
    assert (what.groups, what.networks, what.cached, what.warm_ups) == (8, 0, 0, 4)
    assert what.most_seconds == (8 + 4) * 1.5 * 5  # a group may run on to 5 times its cap
    assert "4 of them after an untimed trial" in what.text()
    assert "at most about 1.5 min" in what.text()
    with pytest.raises(TypeError, match="samples=1.5 must be an integer >= 1"):
        plan([experiment], samples=1.5)  # type: ignore[arg-type]


def test_estimate_draws_a_progress_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`bench estimate` reports its groups on stderr as `bench run` does its trials."""
    stream = io.StringIO()
    estimate(load_spec(write_spec(tmp_path), "full"), samples=2, progress=stream)
    assert stream.getvalue().splitlines()[-1].startswith("estimate tiny (full) [")
    assert "8/8 cells" in stream.getvalue()
    main(["bench", "estimate", str(write_spec(tmp_path)), "--samples", "1"], print)
    assert "estimate tiny (full) [" in capsys.readouterr().err


def test_an_interrupted_estimate_does_not_promise_a_resume(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Ctrl-C in ``estimate`` says nothing was saved; in ``run`` it says how to continue."""

    def interrupted(args: object, out: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "bench_estimate", interrupted)
    assert main(["bench", "estimate", str(write_spec(tmp_path))], print) == 130
    err = capsys.readouterr().err
    assert "nothing was saved" in err and "--resume" not in err
    monkeypatch.setattr(cli, "bench_run", interrupted)
    assert main(["bench", "run", str(write_spec(tmp_path))], print) == 130
    assert "--resume continues" in capsys.readouterr().err


def test_help_shows_the_defaults_and_no_markup(capsys: pytest.CaptureFixture[str]) -> None:
    """``--help`` has no reST double backticks; the defaults and sizes are explained."""
    for argv in (["--help"], ["bench", "estimate", "--help"], ["bench", "run", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = capsys.readouterr().out
        assert "``" not in text
    with pytest.raises(SystemExit):
        main(["bench", "estimate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "seeds timed per cell (default: 2)" in text
    assert "quick: a smaller run of every table" in text


def test_training_time_on_an_idle_core_comes_from_cpu_time(monkeypatch) -> None:
    """A probe that got half a core projects, for an idle core, half its wall time."""
    from ns_pz.experiments import estimate as module

    clock = {"wall": 100.0, "cpu": 5.0}
    monkeypatch.setattr(module.time, "perf_counter", lambda: clock["wall"])
    monkeypatch.setattr(module.time, "process_time", lambda: clock["cpu"])
    probe = module._Probe(1.0, warm_up=0)
    clock.update(wall=102.0, cpu=6.0)  # 2 s of wall time, 1 s of CPU
    probe.step(10, 100)
    assert probe.cpu_share() == 0.5
    assert probe.projected(100) == 20.0  # 10 units in 2 s: 100 in 20 s, 10 s on an idle core


def test_training_that_slows_down_is_projected_at_its_later_rate(monkeypatch) -> None:
    """AlphaZero's episodes cost more as its data grows: the rest goes at the later half's rate.

    Past the warm-up (reached at 2 s), 1 unit a second for 4 s, then 1 unit every 2 s for 4 s:
    the later half (6 s to 10 s) did 2 units in 4 s, so the 92 units left take 184 s more (the
    average since the warm-up, 6 units in 8 s, would say 123).
    """
    from ns_pz.experiments import estimate as module

    clock = {"wall": 0.0}
    monkeypatch.setattr(module.time, "perf_counter", lambda: clock["wall"])
    monkeypatch.setattr(module.time, "process_time", lambda: clock["wall"])
    probe = module._Probe(10.0, warm_up=1)
    stops = []
    for wall, done in [(1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (6, 6), (8, 7), (10, 8)]:
        clock["wall"] = float(wall)
        stops.append(probe.step(done, 100))
    assert stops == [False] * 7 + [True]
    assert probe.projected(100) == pytest.approx(10.0 + 184.0)


def test_worker_start_up_is_counted_once_for_specs_run_one_after_the_other(
    tmp_path: Path,
) -> None:
    """``bench run`` keeps its workers from one spec to the next: a second spec adds its work.

    Two copies of one spec on one worker with a 30 s start-up: 30 s plus twice the trials'
    work, not 60 s plus it.
    """
    from ns_pz.experiments.estimate import CellCost, projection_lines

    first = load_spec(write_spec(tmp_path), "full")
    (tmp_path / "other").mkdir()
    other = tiny_spec(RANDOM, MCTS, full_episodes=6, name="other")
    second = load_spec(write_spec(tmp_path / "other", other), "full")
    cost = CellCost("s", "WN", "random", 1.0, 10, 1.0)
    costs = {first.name: [cost], second.name: [cost]}
    line = projection_lines([first, second], [], costs, workers=1, startup=30.0)[1]
    assert "20 trials" in line and line.endswith("wall 50 s"), line


def _bursty_ends(steps: int) -> list[tuple[float, float]]:
    """``(wall, CPU)`` step ends: a 2 s first step, 0.8 s every fourth (2.4 s the first time)."""
    ends, clock = [], 0.0
    for step in range(1, steps + 1):
        cost = 0.01
        if step == 1:
            cost = 2.0  # building the agent, loading kernels
        elif step % 4 == 3:
            cost = 2.4 if step == 3 else 0.8  # a fine-tuning; the first pays its set-up
        clock += cost
        ends.append((clock, clock))
    return ends


def test_a_bursty_cost_is_projected_from_whole_bursts_past_the_one_off_ones() -> None:
    """32 steps, past their first quarter, give the long-run rate; 6 steps overstate it."""
    from ns_pz.experiments.estimate import MIN_STEPS, projected_time

    horizon = 2500
    whole = _bursty_ends(horizon)[-1][1]
    wall, cpu = projected_time(_bursty_ends(MIN_STEPS), horizon)
    assert wall == cpu and whole <= cpu <= 1.01 * whole
    early = projected_time(_bursty_ends(6), horizon)[1]  # the cut at one second
    assert early > 1.3 * whole
    with pytest.raises(ValueError, match=r"len\(ends\)=1 must lie in \[2, horizon=2500\)"):
        projected_time(_bursty_ends(1), horizon)


@pytest.mark.parametrize(("step_seconds", "cut_at"), [(2**-10, 1024), (0.125, 32), (0.5, 10)])
def test_the_cap_cuts_after_min_steps_or_at_its_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step_seconds: float, cut_at: int
) -> None:
    """Past the 1 s cap an episode runs on to 32 steps, but never past 5 s."""
    from ns_pz.agents.evaluation import Episode

    from ns_pz.experiments import estimate as module

    clock = {"now": 0.0}
    monkeypatch.setattr(module.time, "perf_counter", lambda: clock["now"])
    monkeypatch.setattr(module.time, "process_time", lambda: clock["now"])

    def play(env: object, agent: object, seed: int, stop: Callable[[int], bool]) -> Episode:
        steps = 0
        while True:
            clock["now"] += step_seconds
            steps += 1
            if stop(steps):
                return Episode(seed, float(steps), steps, (), ())

    monkeypatch.setattr(module, "run_episode", play)
    experiment = load_spec(write_spec(tmp_path, tiny_spec(RANDOM, horizon=5000)), "quick")
    trial = expand(experiment)[0]
    wall, cpu, cut = module._time_trial(experiment, trial, 1.0, at_horizon=False)
    assert cut and wall == cpu == pytest.approx(5000 * step_seconds)
    costs = module._time_group(experiment, expand(experiment)[:2], 2, 1.0, at_horizon=False)
    assert costs.at_horizon and costs.cpu_seconds_per_trial == pytest.approx(5000 * step_seconds)
    # _time_trial's, then _time_group's untimed first play and its timed one
    assert round(clock["now"] / step_seconds) == 3 * cut_at


def test_one_off_costs_are_paid_untimed_once_per_agent_level_and_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An agent's first play in a process (kernels compiled or loaded) is not the one timed.

    The fake episode's first play of each agent × level costs 100 s a step, as a kernel
    compiled mid-episode did: projected to the horizon it read hours where trials take
    milliseconds. Each agent × level plays once untimed, then every timing is the steady one;
    the next spec on the same environment pays nothing again.
    """
    from ns_pz.agents.evaluation import Episode

    from ns_pz.experiments import estimate as module

    clock = {"now": 0.0}
    monkeypatch.setattr(module.time, "perf_counter", lambda: clock["now"])
    monkeypatch.setattr(module.time, "process_time", lambda: clock["now"])
    paid: set[tuple[str, str]] = set()

    def play(env: object, agent: object, seed: int, stop: Callable[[int], bool]) -> Episode:
        first = (type(agent).__name__, str(getattr(env, "notification", "")))
        step = 100.0 if first not in paid else 0.01
        paid.add(first)
        for steps in range(1, 11):
            clock["now"] += step
            if stop(steps):
                break
        return Episode(seed, 0.0, steps, (), ())

    monkeypatch.setattr(module, "run_episode", play)
    experiment = load_spec(write_spec(tmp_path), "full")
    costs = estimate(experiment, samples=2, cell_seconds=60.0)
    assert costs and all(c.seconds_per_trial == pytest.approx(0.1) for c in costs)
    assert len(module._PLAYED) == 4  # two agents at two levels
    assert plan([experiment]).warm_ups == 0  # nothing left to pay in this process


def test_the_estimate_keeps_the_compiled_kernels_it_finds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Inside the stand-in cache numba reads and writes the user's compiled kernels.

    Its folder moved with ``NS_PZ_CACHE_DIR`` into the temporary cache, so every estimate
    compiled every kernel again, inside a timed trial.
    """
    pytest.importorskip("numba")
    from ns_pz.agents.search import numba_cache

    from ns_pz.experiments.estimate import stand_in_cache

    before = numba_cache.cache_dir()
    assert before is not None and before.is_relative_to(tmp_path)
    with stand_in_cache() as stand_ins:
        assert stand_ins.parent != tmp_path / "cache"  # networks go to the temporary cache
        inside = numba_cache.cache_dir()
        assert inside is not None and inside != before
        assert inside.resolve() == before.resolve()
    assert numba_cache.cache_dir() == before


def test_a_kernel_folder_that_cannot_be_made_leaves_the_estimate_running(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A cache folder under a file (or a read-only home) is skipped, not fatal."""
    from ns_pz.experiments import estimate as module

    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setattr(module, "_compiled_kernels_folder", lambda: blocker / "numba")
    with module.stand_in_cache() as stand_ins:
        assert not (stand_ins.parent / "numba").exists()
    costs = estimate(load_spec(write_spec(tmp_path), "full"), samples=1, cell_seconds=60.0)
    assert len(costs) == 8


def test_kernels_compiled_after_an_estimate_still_reach_the_users_folder(tmp_path: Path) -> None:
    """A locator made inside the stand-in cache points at the user's folder, not the link.

    The link's temporary folder is deleted when the estimate ends; a later compile in the same
    process wrote to a new temporary folder of that name, which nothing removed.
    """
    pytest.importorskip("numba")
    from ns_pz.agents.search import numba_cache

    from ns_pz.experiments.estimate import stand_in_cache

    def ours() -> None:  # a function of an ns_pz module's file, as the locator wants
        return None

    source = numba_cache.package_dirs()[0] / "checks.py"
    user = numba_cache.cache_dir()
    assert user is not None
    with stand_in_cache():
        locator = numba_cache.NSPZCacheLocator.from_function(ours, str(source))
        assert locator is not None
    assert locator.get_cache_path().startswith(str(user.resolve()))
