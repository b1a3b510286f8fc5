"""The benchmark script still runs (a smoke run; its figures are read by people, not asserted)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from specs_for_tests import RANDOM, tiny_spec

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_core.py"


def _bench_module(name: str):
    """A script of benchmarks/ imported as a module."""
    import importlib.util

    loaded = importlib.util.spec_from_file_location(name, BENCH.parent / f"{name}.py")
    module = importlib.util.module_from_spec(loaded)
    loaded.loader.exec_module(module)
    return module


def _smoke_output(script: str, folder: Path) -> str:
    """What ``benchmarks/<script> --smoke`` prints, run from ``folder``."""
    return subprocess.run(
        [sys.executable, str(BENCH.parent / script), "--smoke"],
        capture_output=True,
        text=True,
        check=True,
        cwd=folder,
    ).stdout


def test_core_benchmark_smoke_run():
    """bench_core.py --smoke finishes and prints a ratio for every case."""
    out = subprocess.run(
        [sys.executable, str(BENCH), "--smoke"], capture_output=True, text=True, check=True
    ).stdout
    cases = (
        "view none, change every step",
        "view detailed, change every step",
        "game: policy_action + observe, detailed",
        "compat wrapper detailed, every step",
        "AEC cycle, change every step",
        "ns_pz make_vec detailed (arrays)",
        "Gymnasium CartPoleVectorEnv (raw)",
        "save + restore",
    )
    for case in cases:
        assert case in out


def test_search_benchmark_smoke_run(tmp_path):
    """bench_search.py --smoke times a decision and a model step per setting, and AlphaZero."""
    out = _smoke_output("bench_search.py", tmp_path)
    assert "One MCTS decision" in out and "Model step in the rollout loop" in out
    for setting in (
        "FrozenLake m=5 d=100",
        "CliffWalking m=50 d=200",
        "CartPole m=15 d=500 γ=0.5",
        "CartPoleGamma1 m=15 d=500 γ=1.0",
    ):
        assert setting in out
    assert "One AlphaZero (PUCT) decision" in out and "CartPole m=25 d=100" in out


def test_inline_draws_benchmark_smoke_run(tmp_path):
    """bench_inline_draws.py --smoke times a draw and decisions both ways, checked equal."""
    pytest.importorskip("numba")
    out = _smoke_output("bench_inline_draws.py", tmp_path)
    assert "one random() in a compiled loop: Generator" in out
    assert "UCT FrozenLake (m=100)" in out and "PUCT CartPole (m=500)" in out


def test_detector_benchmark_smoke_run():
    """bench_detectors.py --smoke scores every setting of the three single-change specs."""
    bench = BENCH.parent / "bench_detectors.py"
    out = subprocess.run(
        [sys.executable, str(bench), "--smoke", "--agents", "random"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for row in ("| frozenlake-single | cusum | p=0.4 | random | 2 |", "| cartpole-single | "):
        assert row in out
    assert out.count("| cliffwalking-single | cusum |") == 4  # three settings and the control
    assert "| cliffwalking-single | cusum | control | random | 2 | 400 | 0 | 0 | n/a |" in out


@pytest.mark.parametrize(
    ("flag", "needs", "rows"),
    [
        (
            "--learned",
            "sb3_contrib",
            (
                "| CliffWalking, slip 1.0 → 0.8 at 30 | never alarm |",
                "| FrozenLake 8x8, slip 0.7 → 0.4 at 5 | ppo+cusum |",
                "| FrozenLake 8x8, slip 0.7 → 0.4 at 5 | recurrent |",
            ),
        ),
        ("--river", "river", ("| river ADWIN |", "| TabularCusumMonitor(h=10) |")),
    ],
)
def test_detector_benchmark_learned_and_river_smoke_runs(flag, needs, rows):
    """--learned (a learned monitor) and --river (river's detectors) run, each with its extra."""
    pytest.importorskip(needs)
    bench = BENCH.parent / "bench_detectors.py"
    out = subprocess.run(
        [sys.executable, str(bench), flag, "--smoke"], capture_output=True, text=True, check=True
    ).stdout
    for row in rows:
        assert row in out


def test_adversary_benchmark_quick_run():
    """bench_adversary.py --quick prints its table (needs the learn extra)."""
    pytest.importorskip("stable_baselines3")
    bench = BENCH.parent / "bench_adversary.py"
    out = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, check=True
    ).stdout
    for row in ("| FrozenLake, none |", "| FrozenLake, detailed |", "| CartPole, none |"):
        assert row in out


def test_robust_benchmark_quick_run(tmp_path):
    """bench_robust.py --quick trains and scores one agent per method and prints the table."""
    pytest.importorskip("stable_baselines3")
    bench = BENCH.parent / "bench_robust.py"
    command = [sys.executable, str(bench), "--quick", "--seeds", "1", "--workers", "2"]
    out = subprocess.run(
        [*command, "--out", str(tmp_path)], capture_output=True, text=True, check=True
    ).stdout
    for method in ("plain", "dr", "rarl", "rarl-pool"):
        assert f"| {method} | 1 |" in out
        assert (tmp_path / f"{method}_0.json").exists()


def test_fine_tuning_benchmark_small_run(tmp_path):
    """bench_fine_tuning.py prints a before/after line per setting (a tiny network, one seed)."""
    bench = BENCH.parent / "bench_fine_tuning.py"
    small = "{'ddqn': {'total_steps': 600, 'learning_starts': 100}, 'model_steps': 20}"
    out = subprocess.run(
        [sys.executable, str(bench), "frozenlake-single", "--seeds", "1", "--agent", small],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "NS_PZ_CACHE_DIR": str(tmp_path)},
    ).stdout
    for label in ("unchanged", "p=0.4", "p=0.6", "p=0.8"):
        assert f"\n{label}" in out
    assert out.count(" before ") == 4 and "replaced" in out


def test_trial_costs_benchmark_projects_a_truncated_trial(tmp_path):
    """bench_trial_costs.py times a trial cut by --max-steps and projects it (not "= whole")."""
    bench = BENCH.parent / "bench_trial_costs.py"
    argv = [sys.executable, str(bench), "cartpole-single", "--size", "quick", "--agent", "MCTS"]
    argv += ["--setting", "masspole=1", "--seeds", "0", "--max-steps", "20", "--no-estimate"]
    out = subprocess.run(
        argv,
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "NS_PZ_CACHE_DIR": str(tmp_path)},
    ).stdout
    row = out.strip().splitlines()[-1].split()
    assert row[:3] == ["0", "20", "cut"]
    assert row.count("<=") == 2 and row[-1] == "-"


def test_scaling_projection_plays_the_runners_schedule():
    """bench_scaling's --project: trials needing a network wait for it, the rest fill the cores.

    Quick FrozenLake single table, every trial 0.01 s, each network 10 s to train, 1 s of start-up
    per worker: on 16 workers nothing that needs a network ends before 11 s, and the trials
    that need one (spread over all 16) add their share after that.
    """
    from ns_pz.experiments.runner import needed_networks
    from ns_pz.experiments.spec import load_spec
    from ns_pz.experiments.trials import expand

    module = _bench_module("bench_scaling")
    spec = load_spec("frozenlake-single", "quick")
    trials = expand(spec)
    needs = needed_networks(spec, trials)
    log = "".join(f"trained {need.label} in 10.0 s\n" for _, need in needs)
    rows = [
        {
            "setting": t.cell.setting,
            "notification": t.cell.notification,
            "agent": t.agent.label,
            "wall_time": "0.01",
        }
        for t in trials
    ]
    one = {"cpu": 20.0 + 0.01 * len(rows), "wall": 30.0, "log": log, "rows": rows}
    startup = {"seconds": 1.0, "imports": 0.75, "first_uses": 0.25, "trials": 33}
    waiting = {label for label, _ in needs}
    late = sum(t.agent.label in waiting for t in trials) * 0.01
    text = module.projected(spec, one, startup, 16)
    wall = float(text.rsplit("(", 2)[1].split(" s)")[0])
    assert "1.0 s of start-up per worker: 0.8 s of imports, 0.2 s of first uses" in text
    assert "training 2 network(s), 20 s of work, all ready after 11 s" in text
    assert 11.0 + late / 16 - 0.05 <= wall <= 11.0 + late / 14 + 0.05  # printed to 0.1 s
    assert "the runner's own process used 3.0 CPU-s, less" in module.projected(
        spec, {**one, "runner_cpu": 3.0}, startup, 16
    )
    slow = module.projected(spec, {**one, "runner_cpu": 60.0}, startup, 16)
    assert "the runner's own process, 60.0 CPU-s, bounds it (60.0 s)" in slow
    alone = module.projected(spec, {**one, "serial": 5.0}, startup, 16)
    assert "plus 5.0 s the runner works alone" in alone
    assert abs(float(alone.rsplit("(", 2)[1].split(" s)")[0]) - (wall + 5.0)) <= 0.11


def test_scaling_measures_a_workers_start_up_in_a_fresh_process(tmp_path):
    """The probe plays the first seed of each agent × cell in a new process: imports counted."""
    module = _bench_module("bench_scaling")
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_spec(RANDOM))
    from ns_pz.experiments import load_spec
    from ns_pz.experiments.trials import expand

    firsts = {(t.cell, t.agent.label) for t in expand(load_spec(path, "quick"))}
    startup = module.worker_startup(str(path), "quick", tmp_path)
    assert startup["trials"] == len(firsts) == 4  # 2 settings x 2 levels x 1 agent
    assert 0.05 < startup["imports"] < 30.0  # a Python process importing the runner
    assert startup["first_uses"] < 5.0  # the random agent has nothing to load
    with pytest.raises(RuntimeError, match="the start-up probe failed"):
        module.worker_startup(str(tmp_path / "missing.toml"), "quick", tmp_path)


def test_paper_sample_scales_each_cell_and_bounds_it_by_resampling_seeds(tmp_path):
    """Two cells: 10 × (1 + 3) + 2 × 5 = 50 s; resampled seeds keep it within [30, 70]."""
    from ns_pz.experiments import load_spec

    module = _bench_module("bench_paper_sample")
    groups = {("s", "a"): (10.0, [1.0, 3.0]), ("s", "b"): (2.0, [5.0])}
    total, low, high = module.project(groups, draws=500)
    assert total == 50.0
    assert 30.0 <= low < total < high <= 70.0  # 10 × (2, 4, 6) + 10
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_spec(RANDOM))
    with pytest.raises(ValueError, match=r"seeds=5 must lie in \[1, 4\] for tiny"):
        module.sampled(load_spec(path, "quick"), 5)


def test_paper_sample_plays_the_first_seeds_and_projects_them(tmp_path):
    """--seeds 2 of a 4-episode spec: the first two seeds of every cell played and reported."""
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_spec(RANDOM))
    bench = BENCH.parent / "bench_paper_sample.py"
    argv = [sys.executable, str(bench), str(path), "--size", "quick", "--seeds", "2"]
    argv += ["--workers", "1", "--out", str(tmp_path / "out"), "--draws", "50"]
    env = {**os.environ, "NS_PZ_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run(argv, capture_output=True, text=True, check=True, env=env).stdout
    assert "The first 2 seeds of every cell (quick size)" in out
    assert out.strip().splitlines()[-1].split()[0] == "all"
    rows = (tmp_path / "out" / "tiny-quick" / "trials.jsonl").read_text().splitlines()
    assert len(rows) == 2 * 2 * 2  # 2 settings × 2 levels × 1 agent × 2 seeds
    # the run's own cost, read back from its rows
    work = BENCH.parent / "bench_run_work.py"
    argv = [sys.executable, str(work), str(tmp_path / "out")]
    lines = subprocess.run(argv, capture_output=True, text=True, check=True).stdout.splitlines()
    assert lines[0].split()[:4] == ["tiny-quick", "8", "trials", "(0"]
    assert lines[1].split()[0] == "all" and lines[2].split()[0] == "random"
    with pytest.raises(subprocess.CalledProcessError):
        subprocess.run([*argv[:2], str(tmp_path)], capture_output=True, check=True)


def test_detector_benchmark_times_the_wd_column_and_digests_its_notifications():
    """bench_detector.py plays a table's WD cells and prints its costs and a digest."""
    bench = BENCH.parent / "bench_detector.py"
    argv = [sys.executable, str(bench), "cartpole-single", "--size", "quick"]
    argv += ["--seeds", "1", "--steps", "20"]
    runs = [subprocess.run(argv, capture_output=True, text=True, check=True).stdout for _ in "ab"]
    words = runs[0].split()
    assert words[0] == "cartpole-single" and "notifications" in words
    assert runs[0].split()[-1] == runs[1].split()[-1]  # the same notifications each run
