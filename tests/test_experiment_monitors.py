"""The detector column (WD) of experiment specs: loading, running, scoring in the tables."""

from __future__ import annotations

from pathlib import Path

import pytest

from ns_pz.experiments import LocalBackend, ResultStore, SpecError, expand, load_spec, run_spec
from ns_pz.experiments.report import detection_summaries, table
from ns_pz.monitor import PredictionErrorMonitor, TabularCusumMonitor
from ns_pz.monitor.catalog import make_monitor

WATCHED = """
version = 1
name = "watched"
title = "watched CliffWalking"
env = "ns_pz/CliffWalking-v0"
notifications = ["detailed", "none", "detector"]

[monitor]
name = "cusum"
level = "detailed"
params = { threshold = 10.0 }

[change]
kind = "single"
param = "slip"
first_step = 1
to = [0.4]

[sizes.quick]
episodes = 3
horizon = 40

[[agents]]
name = "random"
"""


def write(folder: Path, text: str) -> Path:
    """Write a spec file into ``folder``."""
    path = folder / "watched.toml"
    path.write_text(text)
    return path


def test_detector_column_runs_the_named_monitor_at_its_level(tmp_path: Path) -> None:
    """The WD cell builds the [monitor] at its level; other cells keep the oracle."""
    experiment = load_spec(write(tmp_path, WATCHED))
    assert [c.notification for c in experiment.cells()] == ["detailed", "none", "detector"]
    assert len(expand(experiment)) == 9
    detector_cell = experiment.cells()[2]
    env = experiment.make_env(detector_cell)
    assert isinstance(env._process.monitor, TabularCusumMonitor)
    assert env._process.monitor.threshold == 10.0
    assert env.notification_level.value == "detailed"
    oracle_env = experiment.make_env(experiment.cells()[0])
    assert not isinstance(oracle_env._process.monitor, TabularCusumMonitor)
    assert experiment.to_dict()["monitor"] == {
        "name": "cusum",
        "level": "detailed",
        "params": {"threshold": 10.0},
    }


def test_a_specs_detector_envs_share_one_bound_monitor(tmp_path: Path) -> None:
    """Every WD env of a spec gets the same bound monitor, and it alarms as fresh ones do.

    Its episodes are what a fresh monitor of their own makes of them (the monitor keeps no
    episode's state); another spec gets its own.
    """
    import numpy as np

    from ns_pz import make_gym
    from ns_pz.experiments import spec as spec_module

    before = set(spec_module._DETECTORS)
    experiment = load_spec(write(tmp_path, WATCHED))  # its check builds a WD env too
    cell = experiment.cells()[2]
    envs = [experiment.make_env(cell) for _ in range(3)]
    assert envs[0]._process.monitor is envs[2]._process.monitor
    assert len(set(spec_module._DETECTORS) - before) <= 1  # the check's and the trials' one

    def alarms(env: object, seed: int) -> list[int]:
        observation, _ = env.reset(seed=seed)  # type: ignore[attr-defined]
        rng = np.random.default_rng(seed)
        flagged = []
        for t in range(40):
            observation, *_ = env.step(int(rng.integers(4)))  # type: ignore[attr-defined]
            flagged += [t] if observation["env_change"].any() else []
        return flagged

    shared = [alarms(env, seed) for seed, env in enumerate(envs)]
    fresh = []
    for seed in range(3):
        env = make_gym(
            experiment.env,
            params=experiment.theta0(),
            nature=experiment.nature(cell.index),
            notification=experiment.level_of(cell.notification),
            monitor=make_monitor("cusum", {"threshold": 10.0}),
            max_episode_steps=experiment.horizon,
        )
        assert env._process.monitor is not envs[0]._process.monitor
        fresh.append(alarms(env, seed))
    assert shared == fresh and any(shared)
    other = load_spec(write(tmp_path, WATCHED.replace("threshold = 10.0", "threshold = 9.0")))
    assert other.make_env(cell)._process.monitor is not envs[0]._process.monitor


def test_a_process_keeps_the_detectors_of_its_last_specs_only(tmp_path: Path) -> None:
    """Bound detectors are dropped oldest first beyond the last few specs' (memory bounded)."""
    from ns_pz.experiments import spec as spec_module

    kept = spec_module._DETECTORS_KEPT
    monitors = []
    for k in range(kept + 1):
        text = WATCHED.replace("threshold = 10.0", f"threshold = {20.0 + k}")
        experiment = load_spec(write(tmp_path, text))
        monitors.append(experiment.make_env(experiment.cells()[2])._process.monitor)
    assert len(spec_module._DETECTORS) <= kept
    held = list(spec_module._DETECTORS.values())
    assert monitors[-1] in held and monitors[0] not in held


def test_a_spec_without_monitor_keeps_its_record(tmp_path: Path) -> None:
    """No ``monitor`` key unless one is given: runs from before keep their digest."""
    text = WATCHED.replace(', "detector"]', "]")
    text = text[: text.index("[monitor]")] + text[text.index("[change]") :]
    assert "monitor" not in load_spec(write(tmp_path, text)).to_dict()


def test_detector_trials_record_alarms_and_the_table_scores_them(tmp_path: Path) -> None:
    """Rows carry alarm times; the report adds a detection table for the WD columns."""
    experiment = load_spec(write(tmp_path, WATCHED))
    summary = run_spec(experiment, tmp_path / "out", LocalBackend(1))
    assert summary.failed == 0
    rows = ResultStore(tmp_path / "out").rows()
    wd = [r for r in rows if r["notification"] == "WD"]
    assert len(wd) == 3 and all(r["alarm_times"] is not None for r in wd)
    won = [r for r in rows if r["notification"] == "WON"]
    assert all(r["alarm_times"] == "[]" for r in won)  # at level none nothing is told
    wn = [r for r in rows if r["notification"] == "WN" and r["length"] > 2]
    assert wn and all(r["alarm_times"] == r["change_times"] == "[1]" for r in wn)  # oracle: 0
    scores = detection_summaries(rows)
    assert list(scores) == [("random", "p=0.4 WD")]
    assert scores[("random", "p=0.4 WD")].changes == 3
    text = table(rows, "t", spec=ResultStore(tmp_path / "out").spec_record()["spec"])
    assert "detection (mean delay in steps, false alarms per 1,000 steps, missed)" in text
    assert "| p=0.4 WD |" in text.split("detection")[-1]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace('name = "cusum"', 'name = "nope"'), "monitor 'nope' is not known"),
        (
            lambda t: t.replace("{ threshold = 10.0 }", "{ thresold = 1.0 }"),
            "has no parameter 'thresold'; allowed: threshold",
        ),
        (lambda t: t.replace('level = "detailed"', 'level = "none"'), r"monitor.level: 'none'"),
        (
            lambda t: t.replace('"ns_pz/CliffWalking-v0"', '"ns_pz/CartPole-v0"').replace(
                'param = "slip"\nfirst_step = 1\nto = [0.4]',
                'param = "masspole"\nfirst_step = 1\nto = [1.0]',
            ),
            "monitor: cannot watch ns_pz/CartPole-v0: .*no explicit outcome table",
        ),
        (
            lambda t: t[: t.index("[monitor]")] + t[t.index("[change]") :],
            "'detector' needs a \\[monitor\\] table",
        ),
        (
            lambda t: t.replace(', "detector"]', "]"),
            "monitor: is given but notifications has no 'detector' column",
        ),
    ],
    ids=["unknown-name", "unknown-param", "level-none", "wrong-family", "no-table", "no-column"],
)
def test_bad_monitor_sections_are_refused(tmp_path: Path, edit, message: str) -> None:
    """Each mistake in the monitor section is refused at load, naming the field."""
    with pytest.raises(SpecError, match=message):
        load_spec(write(tmp_path, edit(WATCHED)))


def test_catalog_builds_monitors_and_names_what_is_allowed() -> None:
    """Names build monitors; an unknown name lists the known ones."""
    assert isinstance(make_monitor("prediction_error", {"tolerance": 1e-3}), PredictionErrorMonitor)
    with pytest.raises(ValueError, match="known: oracle, noisy_oracle, cusum, prediction_error"):
        make_monitor("cusm")
