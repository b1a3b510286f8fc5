"""Learning agents in specs: checked without training, trained once by the runner, estimated."""

from __future__ import annotations

import io

import pytest
from ns_pz.agents.learning.artefacts import cache_dir

from ns_pz.experiments import SpecError, load_spec, run_spec
from ns_pz.experiments.backends import LocalBackend
from ns_pz.experiments.runner import train_artefacts
from ns_pz.experiments.trials import expand

SPEC = """
version = 1
name = "learners"
title = "tiny FrozenLake with learners"
env = "ns_pz/FrozenLake-v0"
params = { slip = 1.0 }
notifications = ["detailed", "none"]

[change]
kind = "single"
param = "slip"
first_step = 1
to = [0.8]

[sizes.quick]
episodes = 2
horizon = 20

[sizes.full]
episodes = 2
horizon = 20

[[agents]]
name = "ddqn"
label = "DDQN"
params = { total_steps = 1500, learning_starts = 100 }

[[agents]]
name = "pamcts"
label = "PA"
params = { alpha = 0.5, iterations = 20, depth = 10 }
quick = { ddqn = { total_steps = 1500, learning_starts = 100 } }
full = { ddqn = { total_steps = 1500, learning_starts = 100 } }

[[agents]]
name = "alphazero"
label = "AZ"
params = { episodes = 2, iterations = 8, max_episode_steps = 20 }
"""


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path / "cache"))


def _spec(tmp_path, text=SPEC):
    path = tmp_path / "learners.toml"
    path.write_text(text)
    return load_spec(path, "quick")


def test_loading_a_spec_trains_nothing(tmp_path):
    """Spec checks validate the learners' settings without acting (acting would train)."""
    _spec(tmp_path)
    assert not cache_dir().exists()


def test_bad_learner_settings_fail_at_load(tmp_path):
    """A learner's hyper-parameter out of range is refused with the spec's field."""
    bad = SPEC.replace(
        'total_steps = 1500, learning_starts = 100 }\n\n[[agents]]\nname = "pamcts"',
        'total_steps = 0 }\n\n[[agents]]\nname = "pamcts"',
    )
    with pytest.raises(SpecError, match="total_steps=0 must be >= 1"):
        _spec(tmp_path, bad)


def test_runner_trains_each_network_once_before_the_workers(tmp_path, capfd):
    """DDQN and PA-MCTS share one Q-network; with two workers each network is trained once."""
    spec = _spec(tmp_path)
    progress = io.StringIO()
    summary = run_spec(spec, tmp_path / "out", LocalBackend(2), progress=progress)
    assert summary.failed == 0 and summary.ran == len(expand(spec))
    log = progress.getvalue()
    assert log.count("trained DDQN") == 1 and log.count("trained AlphaZero") == 1
    assert "learners: training 2 network(s)" in log
    # Trained in two processes: each draws plain progress lines on its stderr.
    trained = capfd.readouterr().err
    assert "training DDQN" in trained and "1,500/1,500 steps" in trained and "ETA" in trained
    assert "training AlphaZero" in trained and "2/2 episodes" in trained
    progress = io.StringIO()  # all cached now: nothing to announce, nothing to draw
    run_spec(spec, tmp_path / "again", LocalBackend(1), progress=progress)
    assert "network(s)" not in progress.getvalue() and "training" not in progress.getvalue()
    assert len(list((cache_dir() / "ddqn").glob("*/manifest.json"))) == 1
    assert len(list((cache_dir() / "alphazero").glob("*/manifest.json"))) == 1
    again = train_artefacts(spec, expand(spec))
    assert [cost.trained_now for cost in again] == [False, False]
    assert all(cost.seconds > 0 for cost in again)  # the recorded training time


def test_train_command_builds_then_finds_the_networks(tmp_path):
    """``ns-pz train`` trains the spec's two networks, and a second call finds them cached."""
    from ns_pz.cli import main

    path = tmp_path / "learners.toml"
    path.write_text(SPEC)
    lines: list[str] = []
    assert main(["train", str(path), "--workers", "1"], lines.append) == 0
    assert sum("trained now" in line for line in lines) == 2
    lines.clear()
    assert main(["train", str(path)], lines.append) == 0
    assert sum("cached" in line for line in lines) == 2
    lines.clear()
    argv = ["bench", "estimate", str(path), "--samples", "1", "--workers", "2"]
    assert main(argv, lines.append) == 0
    assert lines[0].startswith("estimate: 0 network(s) to train")
    assert "(2 cached)" in lines[0]
    assert sum(line.startswith("training: ") for line in lines) == 2  # shared ones once
    # Both networks are cached: a run here loads them, so the projection has no training.
    assert sum(line.endswith("s)") and ": cached (trained in" in line for line in lines) == 2
    assert "no network to train" in lines[-2] and "no network to train" in lines[-1]


def test_sigterm_during_parallel_training_stops_the_workers_at_once(tmp_path):
    """Training in worker processes stops with the run, instead of running to its end."""
    import os
    import signal
    import subprocess
    import sys
    import time

    head = SPEC[: SPEC.index("[[agents]]")]
    agents = "".join(
        f'[[agents]]\nname = "ddqn"\nlabel = "D{steps}"\n'
        f"params = {{ total_steps = {steps}, learning_starts = 100 }}\n\n"
        for steps in (400_000, 400_001)  # two distinct networks, minutes of training each
    )
    path = tmp_path / "long.toml"
    path.write_text(head + agents)
    env = {**os.environ, "NS_PZ_CACHE_DIR": str(tmp_path / "cache"), "OMP_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "ns_pz.cli", "bench", "run", str(path), "--workers", "2"]
    run = subprocess.Popen(
        [*argv, "--out", str(tmp_path / "out")],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = run.stderr.readline()  # the first: how many networks it trains
        assert "learners: training 2 network(s)" in line, line
        time.sleep(6)  # the two workers are training now
        assert run.poll() is None
        run.send_signal(signal.SIGTERM)
        started = time.monotonic()
        run.wait(timeout=30)  # it waited for the training to end: minutes
        assert time.monotonic() - started < 10
        assert run.returncode != 0
        assert not list((tmp_path / "cache").rglob("weights.npz"))  # nothing finished
    finally:
        run.kill()


def test_estimate_times_training_for_seconds_and_leaves_the_cache_alone(tmp_path):
    """Missing networks train for --probe-seconds only, as stand-ins in a temporary cache."""
    from ns_pz.cli import main

    path = tmp_path / "learners.toml"
    path.write_text(SPEC.replace("total_steps = 1500", "total_steps = 400000"))
    lines: list[str] = []
    argv = ["bench", "estimate", str(path), "--samples", "1", "--probe-seconds", "1"]
    assert main([*argv, "--cell-seconds", "0.5", "--workers", "1"], lines.append) == 0
    assert lines[0].startswith("estimate: 2 network(s) to train timed for 1 s each (0 cached)")
    ddqn = [line for line in lines if line.startswith("training: DDQN")]
    assert len(ddqn) == 1 and "projected" in ddqn[0] and "of 400,000 steps)" in ddqn[0]
    timed = int(ddqn[0].split("(timed ")[1].split(" of")[0].replace(",", ""))
    assert 100 < timed < 400_000
    projected = float(ddqn[0].split("projected ")[1].split(" s")[0])
    assert projected > 2  # 400,000 steps take far more than the second timed
    assert not cache_dir().exists()  # nothing trained into the user's cache
    assert any("| ≤ " in line for line in lines if "| DDQN |" in line)  # a stand-in: horizon
    assert "training 2 network(s)" in lines[-1] and "all ready after" in lines[-1]
