"""The results directory's size: hyper-parameters stored once, rows packed into one file."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from specs_for_tests import RANDOM, VI_GAMMA, tiny_spec

from ns_pz.experiments import (
    ExperimentSpec,
    LocalBackend,
    ResultStore,
    SpecError,
    load_spec,
    run_spec,
)

SPEC = tiny_spec(RANDOM, VI_GAMMA, horizon=20)
"""32 trials: 2 settings × 2 levels × 2 agents × 4 seeds."""


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished run of SPEC, to copy."""
    folder = tmp_path_factory.mktemp("finished")
    (folder / "tiny.toml").write_text(SPEC)
    run_spec(load_spec(folder / "tiny.toml", "quick"), folder / "out", LocalBackend(1))
    return folder / "out"


def copy_of(finished: Path, tmp_path: Path) -> Path:
    """A copy of the finished run, with the spec file beside it."""
    (tmp_path / "tiny.toml").write_text(SPEC)
    return Path(shutil.copytree(finished, tmp_path / "out"))


def test_hyperparameters_are_stored_once_and_every_row_reads_them_back(finished: Path) -> None:
    """Each row held its agent's hyper-parameters' JSON, in its trial file and in the CSV."""
    spec = load_spec_beside(finished)
    hyper = {a.label: json.dumps(dict(a.hyper), sort_keys=True) for a in spec.agents}
    assert '"gamma": 0.9' in hyper["VI"]
    stored = json.loads((finished / "hyperparameters.json").read_text())
    assert len(stored) == 2 and {"gamma": 0.9}.items() <= stored[_key_of(finished, "VI")].items()
    rows = ResultStore(finished).rows()
    assert len(rows) == 32
    assert all(row["hyperparameters"] == hyper[row["agent"]] for row in rows)
    for text in ((finished / "trials.jsonl").read_text(), (finished / "results.csv").read_text()):
        assert "gamma" not in text
    csv_header = (finished / "results.csv").read_text().splitlines()[0].split(",")
    assert "hyperparameters_key" in csv_header and "hyperparameters" not in csv_header


def test_a_finished_run_is_a_few_files_whatever_its_trial_count(finished: Path) -> None:
    """One 4 KiB file per trial was most of a run's disk: a quick paper run took 56 MB."""
    files = sorted(p.relative_to(finished).as_posix() for p in finished.rglob("*") if p.is_file())
    assert [f for f in files if f != ".lock"] == [
        "hyperparameters.json",
        "results.csv",
        "spec.json",
        "trials.jsonl",
    ]
    rows = (finished / "trials.jsonl").read_text().splitlines()
    assert len(rows) == 32 and max(len(row) for row in rows) < 450


def test_an_old_store_with_hyperparameters_in_its_rows_reads_and_resumes(
    finished: Path, tmp_path: Path
) -> None:
    """A store written before hyperparameters.json: read as it is, packed by --resume."""
    run = copy_of(finished, tmp_path)
    clean = ResultStore(finished).rows()
    for row in clean:  # the old layout: a file per trial, the hyper-parameters inside
        (run / "trials" / f"{row['trial']}.json").write_text(json.dumps(row, sort_keys=True))
    (run / "trials.jsonl").unlink()
    (run / "hyperparameters.json").unlink()
    assert ResultStore(run).rows() == clean
    summary = run_spec(load_spec(tmp_path / "tiny.toml"), run, LocalBackend(1), resume=True)
    assert (summary.ran, summary.skipped) == (0, 32)
    assert not list((run / "trials").glob("*.json"))
    assert ResultStore(run).rows() == clean
    assert json.loads((run / "hyperparameters.json").read_text()) == json.loads(
        (finished / "hyperparameters.json").read_text()
    )


def test_a_row_whose_key_is_missing_is_named_and_its_trial_rerun(
    finished: Path, tmp_path: Path
) -> None:
    """The key's entry gone from hyperparameters.json: its rows are unreadable, resume re-runs."""
    run = copy_of(finished, tmp_path)
    key = _key_of(run, "VI")
    stored = json.loads((run / "hyperparameters.json").read_text())
    del stored[key]
    (run / "hyperparameters.json").write_text(json.dumps(stored))
    store = ResultStore(run)
    assert len(store.rows()) == 16
    unreadable = store.unreadable()
    assert len(unreadable) == 16
    path, reason = unreadable[0]
    assert path == run / "trials.jsonl" and f"hyperparameters_key {key!r} is not in" in reason
    summary = run_spec(load_spec(tmp_path / "tiny.toml"), run, LocalBackend(1), resume=True)
    assert (summary.ran, summary.skipped) == (16, 16)
    assert without_times(ResultStore(run).rows()) == without_times(ResultStore(finished).rows())


def test_a_damaged_hyperparameters_file_is_refused_naming_it(
    finished: Path, tmp_path: Path
) -> None:
    """Not JSON: every row would be unreadable, so the store says which file and what to do."""
    run = copy_of(finished, tmp_path)
    (run / "hyperparameters.json").write_text('{"abc": ')
    with pytest.raises(SpecError, match=f"{run / 'hyperparameters.json'} is not a JSON object"):
        ResultStore(run).rows()


def load_spec_beside(run: Path) -> ExperimentSpec:
    """The spec a run stored in its spec.json."""
    return ExperimentSpec.from_dict(ResultStore(run).spec_record()["spec"])


def without_times(rows: list[dict]) -> list[dict]:
    """Rows without their wall times, the one thing two runs of a trial may differ in."""
    return [{k: v for k, v in r.items() if k != "wall_time"} for r in rows]


def _key_of(run: Path, agent: str) -> str:
    """The hyperparameters_key of ``agent``'s rows in ``run``."""
    for line in (run / "trials.jsonl").read_text().splitlines():
        row = json.loads(line)
        if row["agent"] == agent:
            return row["hyperparameters_key"]
    raise AssertionError(f"no row of {agent}")


def test_a_packed_row_of_another_spec_is_refused_naming_the_trial(
    finished: Path, tmp_path: Path
) -> None:
    """The message names the trial and the spec it belongs to, not a trial file packing removed."""
    run = copy_of(finished, tmp_path)
    lines = (run / "trials.jsonl").read_text().splitlines()
    row = json.loads(lines[0])
    row["spec_hash"] = "0123456789ab"
    (run / "trials.jsonl").write_text("\n".join([json.dumps(row), *lines[1:]]) + "\n")
    digest = json.loads(lines[1])["spec_hash"]
    message = f"{run}: trial {row['trial']} belongs to spec 0123456789ab, not {digest}"
    with pytest.raises(SpecError, match=message):
        ResultStore(run).finished(digest)
