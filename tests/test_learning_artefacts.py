"""Artefact cache: keyed, atomic, checked on load, trained once across processes."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from ns_pz.agents.learning import artefacts
from ns_pz.agents.learning.artefacts import ArtefactError, ArtefactRequest


def _request(**changes):
    fields = dict(
        learner="ddqn",
        family="FrozenLakeFamily(...)",
        theta0={"slip": (0.7, 0.15, 0.15)},
        args={"hidden": (64,), "total_steps": 100},
        seed=0,
        code_version="0.1.0/ddqn-1",
    )
    fields.update(changes)
    return ArtefactRequest(**fields)


WEIGHTS = {"q.0.weight": np.arange(6.0).reshape(2, 3), "q.0.bias": np.ones(2)}


@pytest.mark.parametrize(
    "change",
    [
        {"learner": "alphazero"},
        {"family": "FrozenLakeFamily(other map)"},
        {"theta0": {"slip": (1.0, 0.0, 0.0)}},
        {"args": {"hidden": (64,), "total_steps": 101}},
        {"seed": 1},
        {"code_version": "0.1.0/ddqn-2"},
    ],
)
def test_every_part_of_the_request_changes_the_key(change):
    """Every part of the request changes the key."""
    assert _request(**change).key != _request().key
    assert _request().key == _request().key


def test_round_trip_and_manifest(tmp_path):
    """Round trip and manifest."""
    request = _request()
    where = artefacts.save(request, WEIGHTS, {"seconds": 1.5}, root=tmp_path)
    assert where == tmp_path / "ddqn" / request.key
    loaded = artefacts.load(request, root=tmp_path)
    assert set(loaded) == set(WEIGHTS)
    np.testing.assert_array_equal(loaded["q.0.weight"], WEIGHTS["q.0.weight"])
    manifest = json.loads((where / "manifest.json").read_text())
    assert manifest["request"] == request.record() and manifest["info"] == {"seconds": 1.5}
    assert [p.name for p in (tmp_path / "ddqn").iterdir() if p.name.startswith(".")] == []


def test_cache_dir_follows_the_environment_variable(tmp_path, monkeypatch):
    """Cache dir follows the environment variable."""
    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))
    assert artefacts.cache_dir() == tmp_path / "artefacts"
    monkeypatch.delenv("NS_PZ_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert artefacts.cache_dir() == tmp_path / "xdg" / "ns_pz" / "artefacts"


def test_corrupt_weights_are_refused(tmp_path):
    """Corrupt weights are refused."""
    request = _request()
    where = artefacts.save(request, WEIGHTS, root=tmp_path)
    payload = bytearray((where / "weights.npz").read_bytes())
    payload[-10] ^= 0xFF
    (where / "weights.npz").write_bytes(bytes(payload))
    with pytest.raises(ArtefactError, match="corrupt"):
        artefacts.load(request, root=tmp_path)
    # and load_or_train does not silently retrain over it either
    with pytest.raises(ArtefactError, match="corrupt"):
        artefacts.load_or_train(request, lambda: (WEIGHTS, {}), root=tmp_path)


def test_foreign_artefacts_are_refused(tmp_path):
    """Foreign artefacts are refused."""
    request = _request()
    where = artefacts.save(request, WEIGHTS, root=tmp_path)
    manifest = json.loads((where / "manifest.json").read_text())
    (where / "manifest.json").write_text(json.dumps({**manifest, "format": "something-else"}))
    with pytest.raises(ArtefactError, match="not an ns_pz artefact"):
        artefacts.load(request, root=tmp_path)
    other = {**manifest, "request": _request(seed=7).record()}
    (where / "manifest.json").write_text(json.dumps(other))
    with pytest.raises(ArtefactError, match="made for another request"):
        artefacts.load(request, root=tmp_path)
    (where / "manifest.json").write_text("{not json")
    with pytest.raises(ArtefactError, match="unreadable"):
        artefacts.load(request, root=tmp_path)


def test_missing_artefact_names_the_fix(tmp_path):
    """Missing artefact names the fix."""
    with pytest.raises(ArtefactError, match="ns-pz train"):
        artefacts.load(_request(), root=tmp_path)


def test_a_failed_training_leaves_nothing_under_the_key(tmp_path):
    """A failed training leaves nothing under the key."""

    def boom():
        raise RuntimeError("training crashed")

    with pytest.raises(RuntimeError, match="training crashed"):
        artefacts.load_or_train(_request(), boom, root=tmp_path)
    assert not artefacts.exists(_request(), root=tmp_path)
    leftovers = [p.name for p in (tmp_path / "ddqn").iterdir() if not p.name.endswith(".lock")]
    assert leftovers == []


def test_load_or_train_trains_once_then_loads(tmp_path):
    """Load or train trains once then loads."""
    calls = []

    def train():
        calls.append(1)
        return WEIGHTS, {}

    _, trained = artefacts.load_or_train(_request(), train, root=tmp_path)
    _, again = artefacts.load_or_train(_request(), train, root=tmp_path)
    assert (trained, again, len(calls)) == (True, False, 1)


def test_concurrent_processes_train_a_key_once(tmp_path):
    """Three processes ask for the same missing artefact at once: one trains, all load it."""
    code = textwrap.dedent(
        f"""
        import os, time, numpy as np
        from pathlib import Path
        from ns_pz.agents.learning import artefacts
        request = artefacts.ArtefactRequest("ddqn", "F", {{}}, {{}}, 0, "v")
        def train():
            with open(Path({str(tmp_path)!r}) / "trainings", "a") as f:
                f.write(f"{{os.getpid()}}\\n")
            time.sleep(1.0)
            return {{"w": np.arange(3.0)}}, {{}}
        weights, trained = artefacts.load_or_train(request, train, Path({str(tmp_path)!r}))
        print(weights["w"].tolist(), trained)
        """
    )
    processes = [
        subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
        for _ in range(3)
    ]
    outputs = [p.communicate(timeout=120)[0].strip() for p in processes]
    assert all(p.returncode == 0 for p in processes)
    assert len((tmp_path / "trainings").read_text().splitlines()) == 1
    assert sorted(outputs) == ["[0.0, 1.0, 2.0] False"] * 2 + ["[0.0, 1.0, 2.0] True"]


def test_learning_agents_import_no_torch():
    """Learning agents import no torch."""
    code = (
        "import sys, ns_pz, ns_pz.agents, ns_pz.agents.catalog, ns_pz.agents.learning.entries,"
        " ns_pz.agents.learning.pamcts, ns_pz.experiments.runner;"
        " print('torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_training_runs_on_one_blas_thread_whatever_the_process_has(monkeypatch):
    """A product split over BLAS threads sums in another order: training pins numpy's to one.

    (AlphaZero's full-batch float32 steps trained another quick CliffWalking network on two
    threads, one that failed its quality test.) The training function records the thread
    count of numpy's BLAS (the library a process importing numpy alone loads) while it runs,
    inside a process allowed two.
    """
    from ns_pz.agents.learning import alphazero
    from ns_pz.agents.learning.config import AlphaZeroArgs
    from ns_pz.agents.learning.trained import alphazero_needed
    from threadpoolctl import threadpool_info, threadpool_limits

    import ns_pz

    probe = "import numpy, threadpoolctl; print([i['filepath'] for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas'])"  # noqa: E501
    numpys = set(eval(subprocess.check_output([sys.executable, "-c", probe], text=True)))
    assert numpys

    def threads():
        return [p["num_threads"] for p in threadpool_info() if p["filepath"] in numpys]

    seen = []

    def record(env, args, seed, progress):
        seen.append(threads())
        return {}, {}

    monkeypatch.setattr(alphazero, "train_alphazero", record)
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": [0.7, 0.15, 0.15]})
    with threadpool_limits(limits=2, user_api="blas"):
        outside = threads()
        if outside != [2] * len(outside):
            pytest.skip(f"numpy's BLAS runs {outside} threads at most here, not 2")
        alphazero_needed(env, AlphaZeroArgs(episodes=1)).train()
    assert seen == [[1] * len(outside)]
