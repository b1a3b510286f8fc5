"""Experiment specs, the runner and its backends, resuming, and the reports."""

from __future__ import annotations

import json
import math
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest
from specs_for_tests import RANDOM, VI_GAMMA, tiny_spec

from ns_pz.cli import main
from ns_pz.experiments import (
    LocalBackend,
    ResultStore,
    SpecError,
    expand,
    load_spec,
    run_spec,
    shipped_specs,
)
from ns_pz.experiments.lock import DirectoryLocked
from ns_pz.experiments.report import table

TINY = tiny_spec(RANDOM, VI_GAMMA, full_episodes=6)


def write_spec(folder: Path, text: str = TINY, name: str = "tiny.toml") -> Path:
    """Write a spec file and return its path."""
    path = folder / name
    path.write_text(text)
    return path


def without_times(rows: list[dict]) -> list[dict]:
    """Rows without their wall times, which are the only thing allowed to differ."""
    return [{k: v for k, v in row.items() if k != "wall_time"} for row in rows]


# -- specs -------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(shipped_specs()))
@pytest.mark.parametrize("size", ["quick", "full"])
def test_shipped_specs_load_at_both_sizes(name: str, size: str) -> None:
    """Every shipped spec is valid at both sizes and expands into trials."""
    experiment = load_spec(name, size)
    assert experiment.size == size
    trials = expand(experiment)
    runs = sum(
        1
        for cell in experiment.cells()
        for a in experiment.agents
        if cell.notification in a.notifications
    )
    assert {t.agent.label for t in trials} == {a.label for a in experiment.agents}  # all run
    assert len(trials) == runs * experiment.episodes
    assert len({t.key for t in trials}) == len(trials)


def test_spec_expands_cells_agents_and_seeds(tmp_path: Path) -> None:
    """Settings × levels × agents × seeds, with sized hyper-parameters and θ as written."""
    experiment = load_spec(write_spec(tmp_path), "quick")
    assert experiment.settings() == ["p=0.4", "p=0.9"]
    assert len(expand(experiment)) == 2 * 2 * 2 * 4
    assert experiment.agents[1].hyper == {"gamma": 0.9}
    assert experiment.theta0().slip == pytest.approx((0.7, 0.15, 0.15))
    env = experiment.make_env(experiment.cells()[0])
    env.reset(seed=0)
    env.step(0)
    env.step(0)
    assert env.ground_truth().theta.slip == pytest.approx((0.4, 0.3, 0.3))
    assert env.ground_truth().change_times == (1,)
    assert load_spec(write_spec(tmp_path), "full").episodes == 6


def test_continuous_change_adds_by_each_step_then_holds() -> None:
    """``by`` for ``steps`` steps from ``first_step``: CliffWalking's p 1 -> 0.8 in ten steps."""
    experiment = load_spec("cliffwalking-continuous")
    env = experiment.make_env(experiment.cells()[0])
    env.reset(seed=0)
    seen = []
    for _ in range(13):
        seen.append(round(env.ground_truth().theta.slip[0], 9))  # θ of the coming transition
        env.step(0)  # UP: CliffWalking only ends at the goal
    assert seen == [1.0, 0.98, 0.96, 0.94, 0.92, 0.9, 0.88, 0.86, 0.84, 0.82, 0.8, 0.8, 0.8]
    assert env.ground_truth().change_times == tuple(range(1, 11))


def test_digest_changes_with_anything_that_changes_results(tmp_path: Path) -> None:
    """Same spec, same digest; a different hyper-parameter or size, a different digest."""
    base = load_spec(write_spec(tmp_path), "quick")
    assert base.digest() == load_spec(write_spec(tmp_path), "quick").digest()
    other = write_spec(tmp_path, TINY.replace("gamma = 0.9", "gamma = 0.8"), "other.toml")
    assert load_spec(other, "quick").digest() != base.digest()
    assert load_spec(write_spec(tmp_path), "full").digest() != base.digest()


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('env = "ns_pz/FrozenLake-v0"', 'env = "ns_pz/FrozenLak-v0"', r"env: .*Did you mean"),
        ('name = "random"', 'name = "randm"', r"agents\[0\]\.name: .*did you mean 'random'"),
        ("quick = { gamma = 0.9 }", "quick = { gama = 0.9 }", r"agents\[1\]\.quick: .*'gama'"),
        ("quick = { gamma = 0.9 }", "quick = { gamma = 1.5 }", r"agents\[1\]\.quick: .*gamma"),
        ("params = { slip = 0.7 }", "params = { slipp = 0.7 }", r"params: .*slipp"),
        ("params = { slip = 0.7 }", "params = { slip = 1.7 }", r"params: .*slip"),
        ("to = [0.4, 0.9]", "to = [0.4, 1.9]", r"change\.to\[1\]: .*slip"),
        ("to = [0.4, 0.9]", "to = [0.4, [0.5, 0.5, 0.5]]", r"change\.to\[1\]"),
        ('kind = "single"', 'kind = "sudden"', r"change\.kind: 'sudden'; allowed"),
        ("episodes = 4", "episodes = 0", r"sizes\.quick\.episodes: 0 must be an integer >= 1"),
        (
            "horizon = 30\n\n[sizes.full]",
            "horizon = 30\nseeds = 3\n\n[sizes.full]",
            r"sizes\.quick\.seeds: unknown field",
        ),
        ('title = "tiny FrozenLake"', 'title = "t"\ncolour = "red"', r"colour: unknown field"),
        (
            'notifications = ["detailed", "none"]',
            'notifications = ["loud"]',
            r"notifications: 'loud' is not a notification level",
        ),
        ("version = 1", "version = 7", r"version: 7; this ns_pz reads version 1"),
        ("first_step = 1", "first_step = 30", r"change\.first_step: 30 is not before sizes"),
        ('name = "tiny"', 'name = "../escape"', r"name: '\.\./escape' must be letters"),
        ("episodes = 6", "episodes = -6", r"sizes\.full\.episodes: -6 must be an integer"),
        (
            "quick = { gamma = 0.9 }",
            "quick = { gamma = 0.9 }\nfull = { gama = 0.9 }",
            r"agents\[1\]\.full: .*'gama'",
        ),
        ('name = "random"', 'name = "random"\nparams = { gama = 1 }', r"agents\[0\]\.params"),
        ("to = [0.4, 0.9]", "to = [0.4, 0.4]", r"change\.to: two settings are both labelled"),
        ('label = "VI"', 'label = "random"', r"agents: two agents are labelled 'random'"),
    ],
)
def test_bad_specs_are_refused_naming_file_and_field(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    """Each mistake is caught at load time with the file, the field and what is allowed."""
    assert old in TINY
    path = write_spec(tmp_path, TINY.replace(old, new, 1))
    with pytest.raises(SpecError, match=message) as caught:
        load_spec(path, "quick")
    assert str(path) in str(caught.value)


def test_every_sizes_values_are_checked_and_blamed_on_their_table(tmp_path: Path) -> None:
    """A bad value at the size not run, a bad common value, a misspelt nested name: all refused.

    Only the size being loaded was built, so ``full = { iterations = -300 }`` passed a quick
    load; a bad value in ``params`` was reported under the size table; a nested table's
    typo came back as a bare TypeError of the settings class.
    """
    mcts = '[[agents]]\nname = "mcts"\nparams = { gamma = 0.9 }\nquick = { iterations = 20 }\n'
    cases = (
        (mcts + "full = { iterations = -300 }\n", r"agents\[0\]\.full: iterations=-300"),
        (mcts.replace("gamma = 0.9", "gamma = -0.9"), r"agents\[0\]\.params: gamma=-0.9"),
        (
            '[[agents]]\nname = "pamcts"\nfull = { ddqn = { total_stepz = 10 } }\n',
            r"agents\[0\]\.full: ddqn has no setting 'total_stepz' \(did you mean "
            r"'total_steps'\?\); allowed: \[",
        ),
    )
    for agent, message in cases:
        path = write_spec(tmp_path, tiny_spec(agent, full_episodes=2))
        for size in ("quick", "full"):
            with pytest.raises(SpecError, match=message):
                load_spec(path, size)
    overridden = mcts.replace("gamma = 0.9", "gamma = -0.9").replace(
        "quick = { iterations = 20 }", "quick = { gamma = 0.9 }"
    )
    both = overridden + "full = { gamma = 0.9, iterations = -3 }\n"  # params' value unused
    with pytest.raises(SpecError, match=r"agents\[0\]\.full: iterations=-3"):
        load_spec(write_spec(tmp_path, tiny_spec(both, full_episodes=2)), "quick")
    text = tiny_spec(mcts + "full = { iterations = 300 }\n", full_episodes=2)
    assert load_spec(write_spec(tmp_path, text), "quick").agents[0].hyper["iterations"] == 20


def test_out_naming_a_runs_own_folder_is_refused(tmp_path: Path) -> None:
    """``--out`` is the folder runs go in; a run's own folder there nested a new run in it."""
    spec = str(write_spec(tmp_path))
    out = tmp_path / "o"
    assert main(["bench", "run", spec, "--out", str(out), "--workers", "1"], print) == 0
    lines: list[str] = []
    argv = ["bench", "run", spec, "--out", str(out / "tiny-quick"), "--resume"]
    assert main(argv, lines.append) == 2
    assert not (out / "tiny-quick" / "tiny-quick").exists()


def test_a_tabular_planner_on_cartpole_is_refused(tmp_path: Path) -> None:
    """A planning agent that needs an outcome table cannot be asked to plan CartPole."""
    text = (
        TINY.replace("ns_pz/FrozenLake-v0", "ns_pz/CartPole-v0")
        .replace("params = { slip = 0.7 }", "")
        .replace('param = "slip"', 'param = "masspole"')
        .replace("to = [0.4, 0.9]", "to = [1.0]")
    )
    with pytest.raises(SpecError, match=r"agents\[1\]\.name: .*outcome table"):
        load_spec(write_spec(tmp_path, text), "quick")


def test_agents_that_cannot_act_in_the_env_are_refused_at_load(tmp_path: Path) -> None:
    """MCTS needs discrete actions: on Pendulum it is refused before any trial runs."""
    text = (
        TINY.replace("ns_pz/FrozenLake-v0", "ns_pz/Pendulum-v0")
        .replace("params = { slip = 0.7 }", "")
        .replace('param = "slip"', 'param = "mass"')
        .replace("to = [0.4, 0.9]", "to = [2.0]")
        .replace('name = "random"', 'name = "mcts"')
        .replace('name = "value_iteration"\nlabel = "VI"\nquick = { gamma = 0.9 }\n', "")
    )
    with pytest.raises(SpecError, match=r"agents\[0\]\.name: agent 'mcts' cannot act in"):
        load_spec(write_spec(tmp_path, text), "quick")


def test_continuous_change_by_zero_is_refused(tmp_path: Path) -> None:
    """A continuous change that changes nothing is a mistake in the spec."""
    text = TINY.replace('kind = "single"', 'kind = "continuous"').replace(
        "to = [0.4, 0.9]", "by = 0.0"
    )
    with pytest.raises(SpecError, match=r"change\.by: 0\.0 must be a finite, non-zero number"):
        load_spec(write_spec(tmp_path, text), "quick")


def test_a_trial_that_calls_sys_exit_is_an_error_row(tmp_path: Path) -> None:
    """SystemExit inside an agent cannot end the run silently."""
    text = TINY.replace('name = "random"', 'name = "agents_for_tests:exits_politely_on_cell"')
    experiment = load_spec(write_spec(tmp_path, text), "quick")
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(1))
    rows = ResultStore(tmp_path / "out").rows()
    assert summary.ran == len(rows) == 32 and summary.failed > 0
    assert all("SystemExit" in r["error"] for r in rows if r["status"] == "error")


def test_resume_refuses_trial_files_of_another_spec(tmp_path: Path) -> None:
    """Trial files left by another spec (spec.json deleted) are never adopted."""
    run_spec(load_spec(write_spec(tmp_path)), tmp_path / "out", LocalBackend(1))
    (tmp_path / "out" / "spec.json").unlink()
    other = load_spec(write_spec(tmp_path, TINY.replace("horizon = 30", "horizon = 10")))
    with pytest.raises(SpecError, match="trial results but no spec.json"):
        run_spec(other, tmp_path / "out", LocalBackend(1), resume=True)


def test_cli_checks_every_output_directory_before_running(tmp_path: Path) -> None:
    """With two specs, a foreign directory for the second stops the run before the first runs."""
    first = write_spec(tmp_path, TINY.replace('name = "tiny"', 'name = "one"'), "one.toml")
    second = write_spec(tmp_path, TINY.replace('name = "tiny"', 'name = "two"'), "two.toml")
    out = tmp_path / "o"
    assert main(["bench", "run", str(second), "--out", str(out), "--workers", "1"], print) == 0
    changed = TINY.replace('name = "tiny"', 'name = "two"').replace("horizon = 30", "horizon = 9")
    write_spec(tmp_path, changed, "two.toml")
    code = main(["bench", "run", str(first), str(second), "--out", str(out)], print)
    assert code == 2
    assert not (out / "one-quick").exists()
    assert main(["bench", "run", str(first), str(first), "--out", str(out)], print) == 2


def test_unknown_spec_name_lists_shipped(tmp_path: Path) -> None:
    """A name that is neither shipped nor a file is refused with the shipped names."""
    with pytest.raises(SpecError, match="frozenlake-single"):
        load_spec("frozen-single")


# -- running -------------------------------------------------------------------------------------
def test_local_pool_gives_the_rows_of_a_serial_run(tmp_path: Path) -> None:
    """Two worker processes or one: the same rows, bit for bit (wall times aside)."""
    experiment = load_spec(write_spec(tmp_path), "quick")
    serial = run_spec(experiment, tmp_path / "serial", LocalBackend(1))
    pooled = run_spec(experiment, tmp_path / "pooled", LocalBackend(2))
    assert serial.ran == pooled.ran == 32 and serial.failed == pooled.failed == 0
    rows = ResultStore(tmp_path / "serial").rows()
    assert without_times(rows) == without_times(ResultStore(tmp_path / "pooled").rows())
    assert {r["status"] for r in rows} == {"ok"}
    assert (tmp_path / "serial" / "results.csv").read_text().count("\n") == 33


def test_ray_backend_gives_the_same_rows(tmp_path: Path) -> None:
    """Ray started locally in the test gives exactly the local rows."""
    pytest.importorskip("ray")
    from ns_pz.experiments import RayBackend

    experiment = load_spec(write_spec(tmp_path), "quick")
    run_spec(experiment, tmp_path / "local", LocalBackend(1))
    run_spec(experiment, tmp_path / "ray", RayBackend(2))
    local = without_times(ResultStore(tmp_path / "local").rows())
    assert local == without_times(ResultStore(tmp_path / "ray").rows())


def test_interrupted_run_resumes_to_the_uninterrupted_rows(tmp_path: Path) -> None:
    """Ctrl-C after a few trials, then --resume: exactly the rows of one clean run."""
    experiment = load_spec(write_spec(tmp_path), "quick")
    seen = []

    def interrupt(row: dict) -> None:
        seen.append(row)
        if len(seen) == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_spec(experiment, tmp_path / "cut", LocalBackend(1), on_row=interrupt)
    assert len(ResultStore(tmp_path / "cut").rows()) == 5
    with pytest.raises(SpecError, match="--resume"):
        run_spec(experiment, tmp_path / "cut", LocalBackend(1))
    summary = run_spec(experiment, tmp_path / "cut", LocalBackend(2), resume=True)
    assert (summary.skipped, summary.ran) == (5, 27)
    run_spec(experiment, tmp_path / "clean", LocalBackend(1))
    resumed = without_times(ResultStore(tmp_path / "cut").rows())
    assert resumed == without_times(ResultStore(tmp_path / "clean").rows())


def test_killed_run_resumes_losing_and_duplicating_nothing(tmp_path: Path) -> None:
    """A kill -9 of the whole run mid-way; the resumed directory equals a clean run's."""
    text = TINY.replace("episodes = 4", "episodes = 40")
    spec_path = write_spec(tmp_path, text)
    out = tmp_path / "killed"
    command = [sys.executable, "-m", "ns_pz.cli", "bench", "run", str(spec_path)]
    command += ["--out", str(out), "--workers", "1"]
    process = subprocess.Popen(
        command,
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    trials = out / "tiny-quick" / "trials"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(trials.glob("*.json"))) < 20:
        time.sleep(0.01)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    done_before = len(list(trials.glob("*.json")))
    assert 20 <= done_before < 320, "the run finished before it could be killed"
    experiment = load_spec(spec_path, "quick")
    summary = run_spec(experiment, out / "tiny-quick", LocalBackend(1), resume=True)
    assert summary.skipped == done_before and summary.ran == 320 - done_before
    run_spec(experiment, tmp_path / "clean", LocalBackend(1))
    resumed = without_times(ResultStore(out / "tiny-quick").rows())
    assert resumed == without_times(ResultStore(tmp_path / "clean").rows())
    assert len(resumed) == 320


HOLD_LOCK = """
import sys, time
from ns_pz.experiments.lock import locked
with locked(sys.argv[1]):
    print("locked", flush=True)
    time.sleep(60)
"""


def test_a_second_run_into_a_locked_directory_exits_2_naming_it_and_the_holder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two runs on one --out: the second is refused with the directory and the holder's PID."""
    spec_path = write_spec(tmp_path)
    target = tmp_path / "o" / "tiny-quick"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD_LOCK, str(target)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        command = ["bench", "run", str(spec_path), "--out", str(tmp_path / "o"), "--workers", "1"]
        assert main(command, print) == 2
        error = capsys.readouterr().err
        assert str(target) in error and f"PID {holder.pid}" in error
        assert not list((target / "trials").glob("*.json"))
        with pytest.raises(DirectoryLocked, match=f"PID {holder.pid}"):
            run_spec(load_spec(spec_path), target, LocalBackend(1))
    finally:
        holder.kill()
        holder.wait()
    # A holder that died (here: killed) leaves the lock file but not the lock.
    assert main(command, print) == 0


def test_a_truncated_trial_file_is_named_skipped_by_table_and_rerun_by_resume(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A trial file cut short: `bench table` names it and goes on; --resume re-runs its trial."""
    spec_path = write_spec(tmp_path)
    out = tmp_path / "o"
    run = ["bench", "run", str(spec_path), "--out", str(out), "--workers", "1"]
    assert main(run, print) == 0
    clean = without_times(ResultStore(out / "tiny-quick").rows())
    victim = out / "tiny-quick" / "trials.jsonl"  # where the finished run packed its rows
    lines = victim.read_text().splitlines()
    lines[3] = lines[3][:40]
    victim.write_text("\n".join(lines) + "\n")
    (out / "tiny-quick" / "trials" / "stray.json").write_text("[1, 2]")
    capsys.readouterr()
    assert main(["bench", "table", str(out)], print) == 0
    error = capsys.readouterr().err
    assert f"skipped {victim}: unreadable (line 4: " in error
    assert "stray.json: unreadable" in error
    assert main([*run, "--resume"], print) == 0
    captured = capsys.readouterr()
    assert f"{victim} is unreadable (line 4: " in captured.err
    assert "(1 trials run, 31 already done, 0 failed" in captured.out
    (out / "tiny-quick" / "trials" / "stray.json").unlink()
    assert without_times(ResultStore(out / "tiny-quick").rows()) == clean
    assert ResultStore(out / "tiny-quick").unreadable() == []


def test_a_corrupt_spec_record_is_named(tmp_path: Path) -> None:
    """A spec.json cut short is refused with its path, not a bare JSONDecodeError."""
    run_spec(load_spec(write_spec(tmp_path)), tmp_path / "out", LocalBackend(1))
    meta = tmp_path / "out" / "spec.json"
    meta.write_text(meta.read_text()[:10])
    with pytest.raises(SpecError, match=f"{meta} is not valid JSON"):
        ResultStore(tmp_path / "out").spec_record()


def test_results_of_another_spec_are_refused(tmp_path: Path) -> None:
    """No silent mixing: a directory of another spec (or size) is refused, even on resume."""
    run_spec(load_spec(write_spec(tmp_path), "quick"), tmp_path / "out", LocalBackend(1))
    with pytest.raises(SpecError, match=r"a different spec .*: agents, episodes, size differ"):
        run_spec(
            load_spec(write_spec(tmp_path), "full"), tmp_path / "out", LocalBackend(1), resume=True
        )


def test_a_trial_that_raises_is_recorded_and_the_run_goes_on(tmp_path: Path) -> None:
    """A user's agent (``module:builder``) failing on one cell: error rows, the rest finish."""
    text = TINY.replace('name = "random"', 'name = "agents_for_tests:raises_on_cell"')
    experiment = load_spec(write_spec(tmp_path, text), "quick")
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(1))
    rows = ResultStore(tmp_path / "out").rows()
    errors = [r for r in rows if r["status"] == "error"]
    assert summary.ran == len(rows) == 32
    assert 0 < summary.failed == len(errors) < 16
    for row in errors:
        assert "RuntimeError: boom on cell 8" in row["error"] and row["return"] is None
    assert "failed)" in table(rows, "t")  # the table says how many episodes a cell lost


def test_a_crashed_worker_is_recorded_and_the_pool_restarts(tmp_path: Path) -> None:
    """A worker killed mid-trial: its trials become error rows, every other trial still runs."""
    text = TINY.replace(
        'name = "random"', 'name = "agents_for_tests:exits_on_cell"\nlabel = "flaky"'
    )
    experiment = load_spec(write_spec(tmp_path, text), "quick")
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(2))
    rows = ResultStore(tmp_path / "out").rows()
    assert summary.ran == len(rows) == 32
    crashed = {r["trial"] for r in rows if r["status"] == "error"}
    assert all("worker process died" in r["error"] for r in rows if r["trial"] in crashed)
    assert crashed, "the agent should have killed some workers"
    # Exactly the trials that reach the cell (the raising twin shows which) are lost ...
    twin = TINY.replace(
        'name = "random"', 'name = "agents_for_tests:raises_on_cell"\nlabel = "flaky"'
    )
    twin_spec = load_spec(write_spec(tmp_path, twin, "twin.toml"), "quick")
    run_spec(twin_spec, tmp_path / "twin", LocalBackend(1))
    twin_rows = ResultStore(tmp_path / "twin").rows()
    assert {r["trial"] for r in twin_rows if r["status"] == "error"} == crashed
    # ... and every trial that finished is exactly what an undisturbed run gives.
    expected = {r["trial"]: r for r in without_times(twin_rows)}
    for row in without_times(rows):
        if row["status"] == "ok":
            assert {**row, "spec_hash": None} == {**expected[row["trial"]], "spec_hash": None}


def test_unimportable_user_agent_is_refused(tmp_path: Path) -> None:
    """``module:builder`` that does not exist: refused at load time, naming the field."""
    text = TINY.replace('name = "random"', 'name = "no_such_module:build"')
    with pytest.raises(SpecError, match=r"agents\[0\]\.name: .*cannot be imported"):
        load_spec(write_spec(tmp_path, text), "quick")


# -- reports -----------------------------------------------------------------------------------
def test_table_of_random_agent_matches_a_hand_computation(tmp_path: Path) -> None:
    """Mean ± SE (ddof=1) per cell, computed here by hand from the stored rows."""
    experiment = load_spec(write_spec(tmp_path, TINY.replace("episodes = 4", "episodes = 12")))
    run_spec(experiment, tmp_path / "out", LocalBackend(1))
    store = ResultStore(tmp_path / "out")
    rows = store.rows()
    text = table(rows, "t", spec=store.spec_record()["spec"], digits=3)
    header = [line for line in text.splitlines() if line.startswith("| agent")][0]
    columns = [c.strip() for c in header.strip("|").split("|")][1:]
    assert columns == ["p=0.4 WN", "p=0.4 WON", "p=0.9 WN", "p=0.9 WON"]
    random_line = [line for line in text.splitlines() if line.startswith("| random")][0]
    entries = [c.strip().strip("*") for c in random_line.strip("|").split("|")][1:]  # bold: best
    for column, entry in zip(columns, entries, strict=True):
        setting, level = column.split()
        values = [
            r["return"]
            for r in rows
            if r["agent"] == "random" and r["setting"] == setting and r["notification"] == level
        ]
        assert len(values) == 12
        mean = sum(values) / len(values)
        se = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1) / len(values))
        assert entry == f"{mean:.3f} ± {se:.3f}"
        assert math.isclose(statistics.stdev(values) / math.sqrt(12), se)


def test_cli_run_table_plot_and_exit_codes(tmp_path: Path) -> None:
    """The command line: a run prints its table; errors exit 2 with a message; --help works."""
    lines: list[str] = []
    spec_path = write_spec(tmp_path)
    code = main(
        ["bench", "run", str(spec_path), "--out", str(tmp_path / "o"), "--workers", "1"],
        out=lines.append,
    )
    assert code == 0
    assert any("| VI |" in line for line in lines)
    lines.clear()
    assert main(["bench", "table", str(tmp_path / "o"), "--format", "latex"], lines.append) == 0
    assert r"\begin{tabular}" in lines[0]
    pytest.importorskip("matplotlib")
    assert main(["bench", "plot", str(tmp_path / "o")], lines.append) == 0
    assert (tmp_path / "o" / "tiny-quick" / "plots" / "means.png").stat().st_size > 1000
    assert main(["bench", "run", "no-such-spec"], lines.append) == 2
    assert main(["bench", "table", str(tmp_path / "nothing")], lines.append) == 2
    with pytest.raises(SystemExit) as exited:
        main(["bench", "run", "--help"])
    assert exited.value.code == 0


def test_version_flag_prints_the_version(capsys: pytest.CaptureFixture[str]) -> None:
    """``ns-pz --version`` prints the package version and exits 0."""
    import ns_pz

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"ns-pz {ns_pz.__version__}"


def test_bench_list_names_every_shipped_spec() -> None:
    """``bench list`` shows each shipped spec."""
    lines: list[str] = []
    assert main(["bench", "list"], lines.append) == 0
    text = "\n".join(lines)
    for name in shipped_specs():
        assert name in text


def test_spec_record_is_json(tmp_path: Path) -> None:
    """spec.json holds the digest and the resolved spec."""
    experiment = load_spec(write_spec(tmp_path))
    run_spec(experiment, tmp_path / "o", LocalBackend(1))
    record = json.loads((tmp_path / "o" / "spec.json").read_text())
    assert record["digest"] == experiment.digest()
    assert record["spec"]["settings"] == ["p=0.4", "p=0.9"]


@pytest.mark.parametrize("name", sorted(shipped_specs()))
def test_spec_round_trips_through_its_record(name: str) -> None:
    """A results directory's spec.json rebuilds the very same spec (same digest)."""
    from ns_pz.experiments import ExperimentSpec

    experiment = load_spec(name, "full")
    record = json.loads(json.dumps(experiment.to_dict()))
    assert ExperimentSpec.from_dict(record).digest() == experiment.digest()


def test_tabular_tables_carry_the_optimum_and_no_agent_beats_it(tmp_path: Path) -> None:
    """Every catalogued tabular agent's mean stays below the exact optimum, up to noise."""
    from ns_pz.experiments.optimum import optimum_for
    from ns_pz.experiments.report import summarise

    text = TINY.replace("episodes = 4", "episodes = 100").replace("horizon = 30", "horizon = 100")
    text += '\n[[agents]]\nname = "snapshot_vi"\n\n[[agents]]\nname = "rats"\n'
    text += 'params = { terminal_value = "fl_hack" }\n'
    text += '\n[[agents]]\nname = "mcts"\nparams = { iterations = 50, depth = 30 }\n'
    text += '\n[[agents]]\nname = "ada_mcts"\nnotifications = ["none"]\n'
    text += "params = { iterations = 50, depth = 30, warmup = 10 }\n"
    experiment = load_spec(write_spec(tmp_path, text), "quick")
    run_spec(experiment, tmp_path / "out", LocalBackend(2))
    store = ResultStore(tmp_path / "out")
    record = store.spec_record()["spec"]
    optimum = optimum_for(record)
    assert optimum is not None
    agents, columns, summaries = summarise(store.rows(), record)
    for column in columns:
        setting, level = column.split()
        best = optimum(setting, level)
        assert best is not None and 0.0 < best <= 1.0
        for agent in agents:
            if (agent, column) not in summaries:  # ADA-MCTS runs without notification only
                continue
            summary = summaries[(agent, column)]
            # Returns are 0/1: the standard error of a mean of 100 is at most 0.05.
            assert summary.mean <= best + 4 * 0.05, (agent, column, summary, best)
    text_table = table(store.rows(), "t", optimum=optimum, spec=record)
    assert "| optimum |" in text_table and "regret to the optimum" in text_table


def test_tables_and_figures_say_what_the_labels_and_plus_minus_mean_and_draw_the_optimum(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """WN/WON, ± = one standard error and n under every table and figure; dashed optimum."""
    from ns_pz.experiments.optimum import optimum_for
    from ns_pz.experiments.report import plot, summarise

    run_spec(load_spec(write_spec(tmp_path)), tmp_path / "out", LocalBackend(1))
    store = ResultStore(tmp_path / "out")
    record = store.spec_record()["spec"]
    optimum = optimum_for(record)
    markdown = table(store.rows(), "t", optimum=optimum, spec=record)
    legend = "WN = with notification (told what changed; plans with the current θ); WON = "
    assert markdown.count(legend) == 1
    assert "Mean episode return ± one standard error, n = 4 episodes per cell." in markdown
    latex = table(store.rows(), "t", "latex", optimum, record)
    assert r"$\pm$ one standard error, n = 4 episodes" in latex and "θ" not in latex
    assert r"plans with $\theta_0$" in latex and r"$\theta$\_0" not in latex
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    saved: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *args, **kwargs: saved.append(self))
    plot(store.rows(), "t", tmp_path / "plots", record, optimum)
    means, returns = saved
    _, columns, _ = summarise(store.rows(), record)
    expected = sorted(optimum(*column.split()) for column in columns)  # type: ignore[misc]
    bars = means.axes[0]
    drawn = [c for c in bars.collections if c.get_gid() == "optimum"]
    assert sorted(segment[0][1] for c in drawn for segment in c.get_segments()) == expected
    assert bars.get_legend_handles_labels()[1].count("exact optimum") == 1
    boxes = [line for ax in returns.axes for line in ax.lines if line.get_gid() == "optimum"]
    assert sorted(line.get_xdata()[0] for line in boxes) == expected  # horizontal boxes
    assert any("one standard error, n = 4" in text.get_text() for text in means.texts)
    caption = " ".join(text.get_text() for text in returns.texts)
    assert "Box: quartiles" in caption and "n = 4" in caption
    assert "standard error" not in caption  # a box plot shows no standard error


def test_non_tabular_tables_have_no_optimum_row() -> None:
    """CartPole has no exact optimum: no row, no regret table."""
    from ns_pz.experiments.optimum import optimum_for

    assert optimum_for(load_spec("cartpole-single").to_dict()) is None


def test_a_size_table_merges_nested_tables_with_the_common_ones(tmp_path: Path) -> None:
    """A size's nested table adds to the common one (it replaced it, dropping its keys)."""
    text = TINY.replace(
        'name = "random"',
        'name = "pamcts"\n'
        "params = { ddqn = { hidden = [32], learning_rate = 0.01 } }\n"
        "quick = { ddqn = { total_steps = 1000 } }",
    )
    experiment = load_spec(write_spec(tmp_path, text), "quick")
    assert experiment.agents[0].hyper["ddqn"] == {
        "hidden": [32],
        "learning_rate": 0.01,
        "total_steps": 1000,
    }


@pytest.mark.parametrize(
    ("agent", "params", "match"),
    [
        ("pamcts", "{ iterations = 0 }", "iterations=0"),
        ("pamcts", '{ normalise = "false" }', "normalise='false' must be a bool"),
        ("pamcts", '{ backend = "gpu" }', "backend='gpu'"),
        ("ddqn_wn", "{ epsilon = 5.0 }", "epsilon=5.0"),
    ],
)
def test_learning_agents_acting_settings_are_checked_at_load(
    tmp_path: Path, agent: str, params: str, match: str
) -> None:
    """Before any network trains: a spec with a bad acting setting is refused at load."""
    text = TINY.replace('name = "random"', f'name = "{agent}"\nparams = {params}')
    with pytest.raises(SpecError, match=match):
        load_spec(write_spec(tmp_path, text), "quick")


def test_results_get_the_permissions_a_plain_open_gives(tmp_path: Path) -> None:
    """Written atomically through tempfile (0600) but shared: 0666 minus the umask."""
    import os
    import stat

    mask = os.umask(0o022)  # tempfile's 0600 is then wrong, whatever the caller's umask
    try:
        run_spec(load_spec(write_spec(tmp_path)), tmp_path / "out", LocalBackend(1))
        results = tmp_path / "out" / "results.csv"
        for path in (results, tmp_path / "out" / "spec.json"):
            assert stat.S_IMODE(path.stat().st_mode) == 0o644, path
        results.chmod(0o640)  # the user's own choice survives a rewrite
        ResultStore(tmp_path / "out").write_csv()
        assert stat.S_IMODE(results.stat().st_mode) == 0o640
    finally:
        os.umask(mask)
