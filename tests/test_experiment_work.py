"""A run's work: networks before the trials that need them, batches of short trials."""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from specs_for_tests import RANDOM, VI, tiny_spec

from ns_pz.experiments import LocalBackend, expand, load_spec
from ns_pz.experiments.work import Batcher, Job, Schedule, Trained, Training, plan_training

TINY = tiny_spec(RANDOM, VI, to=(0.4,), episodes=3, horizon=20)
"""12 trials: 1 setting × 2 levels × 2 agents × 3 seeds."""


@pytest.fixture
def tiny(tmp_path: Path):
    """The TINY spec, loaded."""
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return load_spec(path, "quick")


# -- batches -----------------------------------------------------------------------------------
def test_a_batch_grows_to_the_target_time_of_its_agent() -> None:
    """First one trial (nothing known), then as many as fit in the target, at most ``most``."""
    batcher = Batcher(target=0.2, most=16)
    assert batcher.size("a") == 1
    batcher.record("a", 0.01)
    batcher.record("a", 0.03)
    assert batcher.size("a") == 10  # 0.2 s / 0.02 s
    batcher.record("b", 1e-6)
    assert batcher.size("b") == 16
    batcher.record("c", 5.0)
    assert batcher.size("c") == 1


@pytest.mark.parametrize(
    ("kwargs", "match"), [({"target": 0}, "target=0 must be > 0"), ({"most": 0}, "most=0")]
)
def test_a_batcher_refuses_bad_settings(kwargs: dict, match: str) -> None:
    """Settings out of range name the parameter and its value."""
    with pytest.raises(ValueError, match=match):
        Batcher(**kwargs)


def test_a_batch_holds_one_agent_only(tiny) -> None:
    """A batch ends where the next trial is another agent's, whatever the size allows."""
    trials = expand(tiny)
    batcher = Batcher(target=1.0)
    for trial in trials:
        batcher.record(trial.agent.label, 0.001)
    ready = deque(trials)
    batches = []
    while ready:
        batches.append(batcher.take(ready))
    assert [t for batch in batches for t in batch] == trials
    assert all(len({t.agent.label for t in batch}) == 1 for batch in batches)
    assert [len(batch) for batch in batches] == [3, 3, 3, 3]


# -- the schedule ----------------------------------------------------------------------------
def _fake_training(tiny, label: str) -> Training:
    """Pretend the agent ``label`` needs one missing network (borrowed from a real need)."""
    from ns_pz.agents.learning.config import DDQNArgs
    from ns_pz.agents.learning.trained import ddqn_needed

    need = ddqn_needed(tiny.make_env(tiny.cells()[0]), DDQNArgs(total_steps=10))
    key = need.request.key
    return Training({key: need}, (key,), {label: frozenset({key})})


def test_networks_start_first_and_their_trials_wait_for_them(tiny) -> None:
    """The missing network is the first job; VI's trials start only once it is trained."""
    training = _fake_training(tiny, "VI")
    schedule = Schedule(tiny, expand(tiny), training)
    first = schedule.next_job()
    assert first is not None and first.need is training.networks[training.missing[0]]
    started = []
    while (job := schedule.next_job()) is not None:
        started.extend(job.trials)
    assert started and {t.agent.label for t in started} == {"random"}
    assert not schedule.done
    key = training.missing[0]
    assert schedule.trained(Trained(key, "net", 1.0, True)) == []
    while (job := schedule.next_job()) is not None:
        started.extend(job.trials)
    assert sorted(t.key for t in started) == sorted(t.key for t in expand(tiny))
    assert schedule.done


def test_the_trials_of_a_network_that_failed_become_error_rows(tiny) -> None:
    """A failed training names the network and its error in each of its trials' rows."""
    training = _fake_training(tiny, "VI")
    schedule = Schedule(tiny, expand(tiny), training)
    schedule.next_job()
    rows = schedule.trained(Trained(training.missing[0], "DDQN net", 1.0, False, "OSError: x"))
    assert len(rows) == 6 and {t.agent.label for t, _ in rows} == {"VI"}
    assert all(r["status"] == "error" for _, r in rows)
    assert "its network DDQN net could not be trained: OSError: x" in rows[0][1]["error"]


def test_a_worker_gets_more_of_the_agent_it_has_played(tiny) -> None:
    """First one trial of each agent × cell; then a worker keeps to the agent it knows."""
    schedule = Schedule(tiny, expand(tiny))
    samples = [schedule.next_job(), schedule.next_job(), schedule.next_job()]
    assert all(job is not None and len(job.trials) == 1 for job in samples)
    assert {job.trials[0].seed for job in samples if job} == {0}
    last = schedule.next_job(warm={"VI"})  # the last sample left is VI's: it goes to VI's worker
    assert last is not None and last.trials[0].agent.label == "VI"
    job = schedule.next_job(warm={"VI"})
    assert job is not None and {t.agent.label for t in job.trials} == {"VI"}
    job = schedule.next_job(warm=set(), warm_counts={"VI": 1})  # a fresh worker: the other agent
    assert job is not None and {t.agent.label for t in job.trials} == {"random"}


def test_a_batch_whose_worker_died_plays_again_one_by_one(tiny) -> None:
    """Trials handed back after their worker died come next, each in a job of its own."""
    schedule = Schedule(tiny, expand(tiny))
    first = schedule.next_job()
    assert first is not None
    again = list(expand(tiny)[4:6])
    schedule.retry_alone(again)
    assert [schedule.next_job(), schedule.next_job()] == [Job(trials=(t,)) for t in again]


def test_a_spec_without_learners_trains_nothing(tiny) -> None:
    """No learning agent: no network, nothing waits."""
    training = plan_training(tiny, expand(tiny))
    assert (dict(training.networks), training.missing) == ({}, ())


# -- in a pool ---------------------------------------------------------------------------------
LEARNER = """
[[agents]]
name = "ddqn"
label = "DDQN"
notifications = ["none"]
params = { total_steps = 1500, learning_starts = 100 }

[[agents]]
name = "alphazero"
label = "AZ"
notifications = ["none"]
params = { episodes = 2, iterations = 8, max_episode_steps = 20 }
"""


def test_networks_train_side_by_side_while_other_trials_run(tmp_path: Path, monkeypatch) -> None:
    """Two networks on three workers go to two of them at once; trials needing none to the third.

    What the pool is handed is checked, not clock times: when a spawned worker actually starts
    its job depends on the machine's load (on two busy cores, one worker's start-up can outlast
    the other's whole training).
    """
    from ns_pz.experiments.pool import Pool

    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "learners.toml"
    path.write_text(TINY + LEARNER)
    experiment = load_spec(path, "quick")
    trials = expand(experiment)
    training = plan_training(experiment, trials)
    assert len(training.missing) == 2
    handed: list[tuple[int, Job]] = []
    submit = Pool.submit

    def recording_submit(pool, worker, job, *args):
        handed.append((worker.index, job))
        return submit(pool, worker, job, *args)

    monkeypatch.setattr(Pool, "submit", recording_submit)
    events: list[tuple[str, object]] = []
    on_trained = lambda result: events.append(("net", result))  # noqa: E731
    for trial, row in LocalBackend(3).run(experiment, trials, training, on_trained):
        assert row["status"] == "ok", row["error"]
        events.append((trial.agent.label, row))
    assert [result.trained for kind, result in events if kind == "net"] == [True, True]
    (first, one), (second, two), (third, three) = handed[:3]
    assert one.need is not None and two.need is not None and {first, second} == {0, 1}
    assert third == 2 and three.need is None and three.trials[0].agent.label == "random"
    order = [kind for kind, _ in events]
    assert order.index("DDQN") > order.index("net")  # its trials waited for its network
    assert len(order) == len(trials) + 2
    assert len({row["trial"] for kind, row in events if kind != "net"}) == len(trials)


# -- projecting a run's time -------------------------------------------------------------------
def test_a_projection_trains_first_and_starts_trials_as_their_networks_land() -> None:
    """Two networks (10 s, 4 s) on two workers; trials needing the short one fill in behind it."""
    from ns_pz.experiments.projection import GroupTime, project

    networks = [("short", 4.0), ("long", 10.0)]
    groups = [
        GroupTime(1.0, 6, frozenset({"short"})),  # 6 s of work, ready at 4 s
        GroupTime(2.0, 1, frozenset({"long"})),  # ready at 10 s
    ]
    two = project(networks, groups, workers=2)
    assert (two.networks, two.training_seconds, two.networks_ready) == (2, 14.0, 10.0)
    assert (two.trials, two.trial_seconds) == (7, 8.0)
    assert two.wall == 12.0  # the short trials end at 10 s, the long one at 10 + 2
    one = project(networks, groups, workers=1, startup=3.0)
    assert one.wall == 3.0 + 14.0 + 8.0  # all in a row, after the start-up
    wide = project([], [GroupTime(1.0, 160)], workers=16, startup=2.0)
    assert wide.wall == 12.0 and "no network to train" in wide.text()
    with pytest.raises(ValueError, match="workers=0 must be an integer >= 1"):
        project([], [], workers=0)


def test_a_long_run_is_forecast_once_every_agent_and_cell_has_a_time(tiny) -> None:
    """Each group's first trial goes first; after the last group's first row, one projection."""
    from ns_pz.experiments.projection import Forecast, samples_first

    trials = samples_first(expand(tiny))
    assert [t.seed for t in trials[:4]] == [0, 0, 0, 0]  # 4 groups: one seed of each first
    assert sorted(t.key for t in trials) == sorted(t.key for t in expand(tiny))
    forecast = Forecast(trials, workers=2, long=10.0)
    said = [forecast.add(trial, {"wall_time": 5.0}) for trial in trials]
    assert said[:3] == [None] * 3 and all(s is None for s in said[4:])
    assert said[3] is not None and "the other 8 trials take 40 s of work" in said[3]
    assert "on 2 worker(s) at this machine's present load, wall 20 s more" in said[3]
    short = Forecast(trials, workers=2, long=10.0)  # 8 × 0.1 s left: not a long run
    assert not any(short.add(trial, {"wall_time": 0.1}) for trial in trials)


def test_a_network_is_sent_as_data_to_a_cache_that_lacks_it(tmp_path: Path) -> None:
    """What a Ray node lacking a network receives: it lands in its cache, checked as any other."""
    import numpy as np
    from ns_pz.agents.learning.artefacts import ArtefactRequest, exists, load, save

    from ns_pz.experiments.work import install, payload

    request = ArtefactRequest("ddqn", "Family()", {"slip": 0.7}, {"hidden": [4]}, 0, "test/1")
    weights = {"w": np.arange(6.0).reshape(2, 3)}
    save(request, weights, {"seconds": 1.5}, tmp_path / "here")
    sent = payload(request, tmp_path / "here")
    assert not exists(request, tmp_path / "node")
    install([sent], tmp_path / "node")
    assert exists(request, tmp_path / "node")
    np.testing.assert_array_equal(load(request, tmp_path / "node")["w"], weights["w"])
    install([sent], tmp_path / "node")  # already there: kept as it is
    assert sent[2] == {"seconds": 1.5}


def test_a_backend_in_a_with_block_keeps_its_workers_between_runs(tiny) -> None:
    """Two runs in one block share the worker processes; after the block they are gone."""
    trials = expand(tiny)
    with LocalBackend(1) as backend:
        first = [row for _, row in backend.run(tiny, trials)]
        pool = backend._pool
        assert pool is not None
        (worker,) = pool.workers
        second = [row for _, row in backend.run(tiny, trials)]
        assert backend._pool is pool and pool.workers == [worker]
        assert worker.warm == {"random", "VI"}
    assert backend._pool is None and not worker.process.is_alive()
    assert [r["return"] for r in first] == [r["return"] for r in second]
    alone = LocalBackend(1)
    list(alone.run(tiny, trials[:1]))
    assert alone._pool is None  # outside a block nothing is kept


def test_a_worker_that_dies_idle_is_replaced_and_the_run_goes_on(tiny) -> None:
    """Killed between jobs, a kept worker is replaced at the next run, which loses nothing."""
    import os
    import signal

    trials = expand(tiny)
    with LocalBackend(1) as backend:
        list(backend.run(tiny, trials[:2]))
        assert backend._pool is not None
        (worker,) = backend._pool.workers
        os.kill(worker.process.pid, signal.SIGKILL)
        worker.process.join()
        rows = [row for _, row in backend.run(tiny, trials)]
        assert backend._pool.workers[0] is not worker
    assert sorted(r["trial"] for r in rows) == sorted(t.key for t in trials)
    assert {r["status"] for r in rows} == {"ok"}


def _child_exit_code() -> int:
    """Start a process of its own and return how it ended (a trial may do this)."""
    import multiprocessing

    child = multiprocessing.get_context("spawn").Process(target=int)
    child.start()
    child.join()
    return child.exitcode


def test_a_job_in_a_worker_may_start_processes_of_its_own() -> None:
    """Workers are daemons to their parent, yet a trial may start processes (SubprocVecEnv)."""
    from ns_pz.experiments.pool import Pool

    pool = Pool(1, "cannot start: {how}")
    try:
        pool.submit(pool.idle()[0], "job", _child_exit_code)
        outcomes = pool.wait()
        while not outcomes:  # the first message only says the worker started
            outcomes = pool.wait()
        assert [(o.job, o.died, o.result) for o in outcomes] == [("job", False, 0)]
    finally:
        pool.close(clean=True)


def _mark_warm() -> None:
    import os

    os.environ["NS_PZ_TEST_WARMED_UP"] = "yes"


def _fail_to_warm_up() -> None:
    raise RuntimeError("no head start today")


def _warm_up_for_a_minute() -> None:
    import time

    time.sleep(60)


def _die_warming_up() -> None:
    import os
    import time

    time.sleep(2)  # the test's first job reaches the worker before it dies
    os._exit(3)


@contextlib.contextmanager
def _one_worker(warm_up: Any) -> Iterator[Callable[..., Any]]:
    """A pool of one worker that warms up with ``warm_up``, stopped at the end.

    ``play(job, function, *args)`` submits to it and returns the job's outcome.
    """
    from ns_pz.experiments.pool import Pool

    pool = Pool(1, "cannot start: {how}", warm_up)

    def play(job: str, function: Callable[..., Any], *args: Any) -> Any:
        pool.submit(pool.idle()[0], job, function, *args)
        return pool.wait()[0]  # a worker's first message (it started) is not an outcome

    try:
        yield play
    finally:
        pool.close(clean=True)


def test_a_worker_warms_up_before_its_first_job() -> None:
    """The warm-up runs in the worker itself, before the job sent meanwhile."""
    import os

    with _one_worker(_mark_warm) as play:
        outcome = play("job", os.getenv, "NS_PZ_TEST_WARMED_UP")
    assert (outcome.job, outcome.died, outcome.result) == ("job", False, "yes")


def test_a_warm_up_that_fails_leaves_the_worker_serving() -> None:
    """A warm-up is only a head start: its failure is not the job's, nor the worker's end."""
    with _one_worker(_fail_to_warm_up) as play:
        outcome = play("job", abs, -3)
    assert (outcome.job, outcome.died, outcome.result) == ("job", False, 3)


def test_a_worker_that_dies_warming_up_is_replaced_by_one_that_does_not_warm_up() -> None:
    """Its job is an error (its process died); the next one runs on its replacement.

    The replacement skips the warm-up, which would kill it again.
    """
    with _one_worker(_die_warming_up) as play:
        first = play("first", abs, -1)
        second = play("second", abs, -2)
    assert (first.job, first.died, first.exitcode) == ("first", True, 3)
    assert (second.job, second.died, second.result) == ("second", False, 2)


def test_closing_does_not_wait_for_a_worker_that_never_had_a_job() -> None:
    """A bad spec stops `bench run` before any job: its workers, still warming up, stop now."""
    import time

    from ns_pz.experiments.pool import Pool

    pool = Pool(2, "cannot start: {how}", _warm_up_for_a_minute)
    start = time.perf_counter()
    pool.close(clean=True)
    assert time.perf_counter() - start < 30
    assert all(worker.process.exitcode is not None for worker in pool.workers)


def test_a_started_local_backend_runs_on_the_workers_it_started() -> None:
    """`start` makes the pool at once; the next run uses it, and closes it at its end."""
    backend = LocalBackend(1)
    try:
        backend.start()
        pool = backend._pool
        assert pool is not None and len(pool.workers) == 1
        spec = load_spec("frozenlake-single", "quick")
        trials = [t for t in expand(spec) if t.agent.name == "random"][:2]
        rows = [row for _, row in backend.run(spec, trials)]
        assert [row["status"] for row in rows] == ["ok", "ok"]
        assert pool.workers[0].used and backend._pool is None
        assert pool.workers[0].process.exitcode is not None  # stopped: no `with` kept it
        backend.start()  # a run with nothing to play stops the workers started for it too
        pool = backend._pool
        assert list(backend.run(spec, [])) == [] and backend._pool is None
        assert pool is not None and pool.workers[0].process.exitcode is not None
    finally:
        backend.close()


@pytest.mark.parametrize("user_setting", [None, "3"])
def test_workers_start_with_one_thread_per_numerical_library(
    monkeypatch: pytest.MonkeyPatch, user_setting: str | None
) -> None:
    """NumPy's OpenBLAS reads its thread count when it loads, before a worker's code runs.

    So the variables must be in the environment the worker starts with; a user's own setting is
    kept, and this process's environment is as it was afterwards.
    """
    import os
    from concurrent.futures import ProcessPoolExecutor

    from ns_pz.workers import THREAD_VARIABLES, worker_context

    for name in THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    if user_setting is not None:
        monkeypatch.setenv("OPENBLAS_NUM_THREADS", user_setting)
    with ProcessPoolExecutor(1, mp_context=worker_context()) as pool:
        seen = {name: pool.submit(os.getenv, name).result() for name in THREAD_VARIABLES}
    assert seen == {
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": user_setting or "1",
        "MKL_NUM_THREADS": "1",
    }
    assert os.environ.get("OPENBLAS_NUM_THREADS") == user_setting
    assert "OMP_NUM_THREADS" not in os.environ
