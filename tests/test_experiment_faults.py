"""The runner and its results directory under faults and misuse.

A trial that kills its process, files in ``trials/`` the store did not write, damaged trial
files and spec records, absurd trial counts, a full disk, bad spec files and a directory in use.
"""

from __future__ import annotations

import errno
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from specs_for_tests import RANDOM, tiny_spec

from ns_pz.cli import main
from ns_pz.experiments import (
    ExperimentSpec,
    LocalBackend,
    ResultStore,
    SpecError,
    expand,
    load_spec,
    run_spec,
)
from ns_pz.experiments.backends import died_message
from ns_pz.experiments.spec import MAX_TRIALS

TINY = tiny_spec(RANDOM)
"""16 trials: 2 settings × 2 levels × 1 agent × 4 seeds."""


def write(folder: Path, text: str = TINY, name: str = "tiny.toml") -> Path:
    """Write a spec file and return its path."""
    path = folder / name
    path.write_text(text)
    return path


def without_times(rows: list[dict]) -> list[dict]:
    """Rows without what may differ between runs (wall times, tracebacks' file paths)."""
    return [{k: v for k, v in r.items() if k not in ("wall_time", "traceback")} for r in rows]


# -- a trial that kills its process ------------------------------------------------------------
def test_one_worker_survives_a_trial_that_kills_its_process_and_resume_goes_on(
    tmp_path: Path,
) -> None:
    """--workers 1 ran trials in the runner's own process: os._exit ended the run, no row.

    Now each such trial is an error row saying how its process ended, every other trial runs,
    and --resume re-runs the failed ones (failing again, recorded again) instead of dying.
    """
    crash = TINY.replace('name = "random"', 'name = "agents_for_tests:exits_on_cell"\nlabel = "x"')
    twin = TINY.replace('name = "random"', 'name = "agents_for_tests:raises_on_cell"\nlabel = "x"')
    experiment = load_spec(write(tmp_path, crash), "quick")
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(1))
    rows = ResultStore(tmp_path / "out").rows()
    assert summary.ran == len(rows) == 16
    crashed = {r["trial"] for r in rows if r["status"] == "error"}
    assert crashed and summary.failed == len(crashed) < 16
    for row in rows:
        if row["trial"] in crashed:
            assert "worker process died (exited with code 3)" in row["error"]
    run_spec(load_spec(write(tmp_path, twin, "twin.toml")), tmp_path / "twin", LocalBackend(1))
    twin_rows = ResultStore(tmp_path / "twin").rows()
    assert {r["trial"] for r in twin_rows if r["status"] == "error"} == crashed
    ok = [{**r, "spec_hash": ""} for r in without_times(rows) if r["status"] == "ok"]
    assert ok == [{**r, "spec_hash": ""} for r in without_times(twin_rows) if r["status"] == "ok"]
    again = run_spec(experiment, tmp_path / "out", LocalBackend(1), resume=True)
    assert (again.ran, again.failed) == (len(crashed), len(crashed))


UNGUARDED = """
import sys
from ns_pz.experiments import LocalBackend, load_spec, run_spec
run_spec(load_spec(sys.argv[1]), sys.argv[2], LocalBackend(1))
"""


def test_a_script_without_a_main_guard_is_told_so_not_given_error_rows(tmp_path: Path) -> None:
    """Spawned workers import the script again and die; that is named, and no trial runs."""
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED)
    done = subprocess.run(
        [sys.executable, str(script), str(write(tmp_path)), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert done.returncode == 1
    assert "RuntimeError: the worker processes ended before they started" in done.stderr
    assert "if __name__ == '__main__':" in done.stderr
    assert not list((tmp_path / "out" / "trials").glob("*.json"))


def test_a_killed_worker_is_described_by_its_signal() -> None:
    """A negative exit code is the signal that killed the process (a segfault, the OOM killer)."""
    assert "killed by signal SIGSEGV" in died_message(-11)
    assert "killed by signal SIGKILL" in died_message(-9)
    assert "exited with code 3" in died_message(3)


# -- files the store did not write, and damaged ones ------------------------------------------
@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished run of TINY (16 trials), to copy and damage."""
    folder = tmp_path_factory.mktemp("finished")
    run_spec(load_spec(write(folder), "quick"), folder / "out", LocalBackend(1))
    return folder


def _copy_run(finished: Path, tmp_path: Path) -> tuple[Path, Path]:
    shutil.copytree(finished / "out", tmp_path / "out" / "tiny-quick")
    return write(tmp_path), tmp_path / "out" / "tiny-quick"


def _packed_lines(run: Path) -> list[str]:
    """The rows a finished run packed into ``trials.jsonl``, as stored."""
    assert not list((run / "trials").glob("*.json"))  # the end of the run packed them
    return (run / "trials.jsonl").read_text().splitlines()


def test_a_stray_copy_of_a_trial_file_is_not_another_episode(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`K (copy).json` (a file manager's copy) was read as a 17th row of a 16-trial run."""
    spec_path, run = _copy_run(finished, tmp_path)
    store = ResultStore(run)
    clean = store.rows()
    line = _packed_lines(run)[0]
    key = json.loads(line)["trial"]
    copy = run / "trials" / f"{key} (copy).json"
    renamed = run / "trials" / "00-renamed-s0.json"  # a valid key, another trial's row
    copy.write_text(line)
    renamed.write_text(line)
    assert store.rows() == clean and len(clean) == 16
    assert {path for path, _ in store.strays()} == {renamed, copy}
    assert store.unreadable() == []
    capsys.readouterr()
    assert main(["bench", "table", str(tmp_path / "out")], print) == 0
    error = capsys.readouterr().err
    assert f"skipped {copy}: not a trial file" in error
    assert f"skipped {renamed}: holds trial {key!r}" in error
    run_command = ["bench", "run", str(spec_path), "--out", str(tmp_path / "out")]
    assert main([*run_command, "--workers", "1", "--resume"], print) == 0
    assert "(0 trials run, 16 already done" in capsys.readouterr().out
    assert copy.exists() and renamed.exists()  # never deleted


@pytest.mark.parametrize(
    ("damage", "said"),
    [
        (lambda row: row.pop("setting"), "no setting"),
        (lambda row: row.update({"return": None}), "return is None, not a number"),
        (lambda row: row.update({"return": "1.0"}), "return is '1.0', not a number"),
        (lambda row: row.update({"status": "done"}), "status is 'done'"),
        (lambda row: row.update({"alarm_times": "[1,"}), "alarm_times is '[1,'"),
    ],
)
def test_a_valid_json_but_incomplete_row_is_named_skipped_and_rerun(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], damage, said: str
) -> None:
    """`bench table` gave a traceback (KeyError, float(None)); now it names the file and line."""
    spec_path, run = _copy_run(finished, tmp_path)
    lines = _packed_lines(run)
    row = json.loads(lines[5])
    damage(row)
    lines[5] = json.dumps(row)
    (run / "trials.jsonl").write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert main(["bench", "table", str(tmp_path / "out")], print) == 0
    error = capsys.readouterr().err
    pack = run / "trials.jsonl"
    assert f"skipped {pack}: unreadable (line 6: not a complete result row: {said}" in error
    assert len(ResultStore(run).rows()) == 15
    run_command = ["bench", "run", str(spec_path), "--out", str(tmp_path / "out")]
    assert main([*run_command, "--workers", "1", "--resume"], print) == 0
    assert "(1 trials run, 15 already done" in capsys.readouterr().out
    assert without_times(ResultStore(run).rows()) == without_times(
        ResultStore(finished / "out").rows()
    )
    assert ResultStore(run).unreadable() == []  # the run that re-ran it dropped the line


def test_a_spec_record_without_settings_is_named_and_its_run_skipped(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`bench table` over two runs, one with a damaged spec.json: it names it, shows the other."""
    _, run = _copy_run(finished, tmp_path)
    shutil.copytree(run, tmp_path / "out" / "other-quick")
    meta = run / "spec.json"
    record = json.loads(meta.read_text())
    del record["spec"]["settings"]
    meta.write_text(json.dumps(record))
    capsys.readouterr()
    shown: list[str] = []
    assert main(["bench", "table", str(tmp_path / "out")], shown.append) == 0
    error = capsys.readouterr().err
    assert f"skipped {run}: {meta} is not a complete spec record ('spec' has no 'settings')" in (
        error
    )
    assert len(shown) == 1 and "tiny FrozenLake" in shown[0]
    assert main(["bench", "table", str(run)], print) == 2  # nothing left to show
    with pytest.raises(SpecError, match="no 'settings'"):
        ResultStore(run).spec_record()


# -- sizes ----------------------------------------------------------------------------------
def test_an_absurd_episode_count_is_refused_at_once(tmp_path: Path) -> None:
    """A spec of 10**9 episodes built its whole trial list (still running after 90 s)."""
    huge = TINY.replace("episodes = 4", "episodes = 1000000000")
    start = time.perf_counter()
    with pytest.raises(SpecError, match=r"sizes.quick.episodes: 1000000000 episodes give 4000"):
        load_spec(write(tmp_path, huge), "quick")
    experiment = load_spec(write(tmp_path), "quick")
    record = {**experiment.to_dict(), "episodes": 10**9}
    with pytest.raises(SpecError, match=f"4000000000 trials .* at most {MAX_TRIALS}"):
        expand(ExperimentSpec.from_dict(record))
    assert time.perf_counter() - start < 5.0


# -- writes that fail -------------------------------------------------------------------------
def test_a_full_disk_names_the_file_and_leaves_no_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ENOSPC named no path and left zero-byte temporary files behind (a row's and the CSV's)."""
    import ns_pz.experiments.store as store_module

    experiment = load_spec(write(tmp_path), "quick")
    store = ResultStore(tmp_path / "out")
    store.prepare(experiment, resume=False)
    row = {"trial": "00-x-s0", "status": "ok", "spec_hash": "h"}

    def full(*args: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(store_module.os, "fsync", full)
    monkeypatch.setattr(store_module.os, "replace", full)  # a trial's row is renamed, not synced
    target = tmp_path / "out" / "trials" / "00-x-s0.json"
    with pytest.raises(OSError, match=f"cannot write {target}: No space left on device"):
        store.write(row)
    with pytest.raises(OSError, match="cannot write .*results.csv: No space left"):
        store.write_csv()
    left = [p.name for p in (tmp_path / "out").rglob("*") if p.is_file()]
    assert sorted(left) == [".lock", "spec.json"] or sorted(left) == ["spec.json"]


def test_a_trials_row_is_renamed_into_place_without_waiting_for_the_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No fsync per row (about 0.9 ms each, and the runner writes every row); all read back."""
    import ns_pz.experiments.store as store_module

    synced: list[int] = []
    monkeypatch.setattr(store_module.os, "fsync", synced.append)
    run_spec(load_spec(write(tmp_path), "quick"), tmp_path / "out", LocalBackend(1))
    assert len(ResultStore(tmp_path / "out").rows()) == 16
    assert len(synced) == 4  # spec.json, hyperparameters.json, the pack, results.csv; no row
    assert not list((tmp_path / "out").rglob("*.tmp"))


def test_a_full_disk_when_taking_the_lock_names_the_lock_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Writing the holder's PID can fail too; the error names the file, the lock is released."""
    import ns_pz.experiments.lock as lock_module

    def full(fd: int, data: bytes) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    with monkeypatch.context() as patch:
        patch.setattr(lock_module.os, "write", full)
        with (
            pytest.raises(OSError, match=f"cannot write the lock file {tmp_path / 'out'}/.lock"),
            lock_module.locked(tmp_path / "out"),
        ):
            pass
    with lock_module.locked(tmp_path / "out"):  # not left held
        pass


# -- bad spec files ---------------------------------------------------------------------------
def test_a_spec_that_is_not_utf8_is_named(tmp_path: Path) -> None:
    """A bare UnicodeDecodeError named no file."""
    path = tmp_path / "latin1.toml"
    path.write_bytes(TINY.replace("tiny FrozenLake", "petit lac gelé").encode("latin-1"))
    with pytest.raises(SpecError, match=f"{path}: not UTF-8 text"):
        load_spec(path)


@pytest.mark.parametrize(
    ("line", "key"),
    [
        ('[[agents]]\nname = "mcts"\nparams = { c = nan }', r"agents\[1\].params.c: nan"),
        ('[[agents]]\nname = "mcts"\nquick = { c = inf }', r"agents\[1\].quick.c: inf"),
        (
            '[[agents]]\nname = "ddqn"\nparams = { hidden = [32.0, nan] }',
            r"agents\[1\].params.hidden\[1\]: nan",
        ),
    ],
)
def test_a_nan_hyper_parameter_is_named_by_its_key(tmp_path: Path, line: str, key: str) -> None:
    """The JSON check said "Out of range float values are not JSON compliant", no key."""
    with pytest.raises(SpecError, match=f"{key} must be a finite number"):
        load_spec(write(tmp_path, TINY + line))


# -- a directory in use -----------------------------------------------------------------------
HOLD_LOCK = """
import sys, time
from ns_pz.experiments.lock import locked
with locked(sys.argv[1]):
    print("locked", flush=True)
    time.sleep(60)
"""


def test_a_second_run_on_a_directory_in_use_is_told_so_not_to_pass_resume(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With results there and a run holding the lock, it was first told to pass --resume."""
    spec_path, run = _copy_run(finished, tmp_path)
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD_LOCK, str(run)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        capsys.readouterr()
        command = ["bench", "run", str(spec_path), "--out", str(tmp_path / "out")]
        assert main([*command, "--workers", "1"], print) == 2
        error = capsys.readouterr().err
        assert f"{run.resolve()} is in use by another run (PID {holder.pid})" in error
        assert "--resume" not in error
    finally:
        holder.kill()
        holder.wait()
    assert main([*command, "--workers", "1"], print) == 2  # free now: results there, no resume
    assert "pass --resume" in capsys.readouterr().err
