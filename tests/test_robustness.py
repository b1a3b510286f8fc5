"""evaluate_robustness and its statistics (no torch needed: fixed policies and ns_pz agents)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from ns_pz.agents import SnapshotValueIteration

from ns_pz.learning import (
    AdversarySearch,
    aggregate_runs,
    cvar,
    evaluate_robustness,
    interquartile_mean,
)
from ns_pz.learning.statistics import bootstrap
from ns_pz.nature import (
    ContinuousScheduler,
    DomainRandomisation,
    IncrementUpdate,
    ScriptedNature,
    ThetaSet,
    Uniform,
)

CARTPOLE = "ns_pz/CartPole-v0"
SHORT = {"max_episode_steps": 100}


def balance(obs):
    """Balances the nominal pole; fails on long poles."""
    s = obs["state"]
    return int(0.1 * s[0] + 0.3 * s[1] + s[2] + 0.5 * s[3] > 0)


def push_right(obs):
    """Always pushes right: falls over quickly."""
    return 1


GROWS = ScriptedNature({"length": IncrementUpdate(ContinuousScheduler(start=1), k=0.05)})


def test_conditions_share_their_seeds_and_the_report_adds_up():
    """Every condition plays seeds seed..seed+n-1; the statistics order as they must.

    A grid member equal to θ_0 repeats the nominal returns exactly.
    """
    report = evaluate_robustness(
        balance,
        CARTPOLE,
        grid={"length": [0.5, 3.0], "masspole": [0.1]},
        natures={"grows": GROWS},
        episodes=6,
        seed=7,
        **SHORT,
    )
    assert report.seeds == tuple(range(7, 13))
    nominal, at_theta0, long_pole, grows = report.conditions
    assert at_theta0.params == {"length": 0.5, "masspole": 0.1}
    assert at_theta0.returns == nominal.returns == (100.0,) * 6
    assert long_pole.mean < 50
    grid = report.row("grid")
    assert grid.conditions == 2
    assert grid.worst.value == pytest.approx(long_pole.mean)
    assert grid.mean.value == pytest.approx((at_theta0.mean + long_pole.mean) / 2)
    assert grid.cvar.value <= grid.quantile.value <= grid.mean.value
    assert grid.mean.low <= grid.mean.value <= grid.mean.high
    assert report.row("grows").mean.value == pytest.approx(grows.mean)
    assert report.row("all").conditions == 4
    with pytest.raises(KeyError, match="no row 'nope'"):
        report.row("nope")


def test_the_same_seed_gives_the_same_report_and_two_policies_meet_the_same_draws():
    """Common random numbers: episode k's randomised θ_0 is the same for every policy.

    So a difference between policies is the policies' own.
    """
    natures = {"dr": DomainRandomisation({"length": Uniform(0.3, 3.0)})}
    first = evaluate_robustness(balance, CARTPOLE, natures=natures, episodes=5, **SHORT)
    again = evaluate_robustness(balance, CARTPOLE, natures=natures, episodes=5, **SHORT)
    assert first.to_dict() == again.to_dict()
    other = evaluate_robustness(push_right, CARTPOLE, natures=natures, episodes=5, **SHORT)
    assert other.seeds == first.seeds
    assert first.row("dr").mean.value > other.row("dr").mean.value


def test_an_ns_pz_agent_is_scored_over_a_theta_set():
    """A planner over FrozenLake's slip: a deterministic lake is solved, a slippery one is not."""
    lake = ThetaSet([{"slip": (1.0, 0.0, 0.0)}, {"slip": (0.4, 0.3, 0.3)}])
    report = evaluate_robustness(
        SnapshotValueIteration(gamma=0.99),
        "ns_pz/FrozenLake-v0",
        grid=lake,
        episodes=20,
        params={"slip": (1.0, 0.0, 0.0)},
        max_episode_steps=100,
    )
    solid, slippery = (c for c in report.conditions if c.group == "grid")
    assert solid.mean == 1.0 and slippery.mean < 0.9
    assert report.row("grid").worst.value == slippery.mean
    assert "| grid | 2 |" in report.table()


def test_the_report_serialises_and_plots(tmp_path):
    """JSON holds every condition; the figure has bars and a heatmap of a 2-parameter grid."""
    pytest.importorskip("matplotlib")
    report = evaluate_robustness(
        balance, CARTPOLE, grid={"length": [0.5, 2.0], "masspole": [0.1, 0.3]}, episodes=2, **SHORT
    )
    data = json.loads(report.to_json())
    assert [c["label"] for c in data["conditions"]][0] == "nominal"
    assert len(data["conditions"]) == 5
    figure = report.plot(str(tmp_path / "robust.png"))
    assert (tmp_path / "robust.png").stat().st_size > 1000
    assert len(figure.axes) == 3  # the bars, the heatmap and its colour bar


def test_bad_arguments_are_named_before_any_episode():
    """Every bad argument is refused by name before an episode runs."""
    with pytest.raises(TypeError, match="policy=3"):
        evaluate_robustness(3, CARTPOLE)
    with pytest.raises(ValueError, match="episodes=0"):
        evaluate_robustness(balance, CARTPOLE, episodes=0)
    with pytest.raises(ValueError, match="alpha=1.5"):
        evaluate_robustness(balance, CARTPOLE, alpha=1.5)
    with pytest.raises(TypeError, match="grid=\\[1, 2\\]"):
        evaluate_robustness(balance, CARTPOLE, grid=[1, 2])
    with pytest.raises(ValueError, match="label 'nominal'"):
        evaluate_robustness(balance, CARTPOLE, natures={"nominal": GROWS})
    with pytest.raises(TypeError, match="natures\\['x'\\]=1"):
        evaluate_robustness(balance, CARTPOLE, natures={"x": 1})
    with pytest.raises(TypeError, match="adversaries="):
        evaluate_robustness(balance, CARTPOLE, adversaries=3)
    with pytest.raises(ValueError, match="trials=0"):
        AdversarySearch(trials=0)


def test_statistics_follow_their_definitions():
    """IQM, CVaR and the paired bootstrap follow their definitions.

    IQM is the 25 %-trimmed mean (as scipy's trim_mean and rliable compute it), CVaR the mean
    of the worst ceil(alpha * n); the bootstrap interval brackets its estimate.
    """
    scipy_stats = pytest.importorskip("scipy.stats")
    rng = np.random.default_rng(0)
    for n in (1, 3, 4, 5, 8, 11):
        values = rng.normal(size=n)
        assert interquartile_mean(values) == pytest.approx(scipy_stats.trim_mean(values, 0.25))
    assert cvar(np.array([5.0, 1.0, 3.0, 2.0, 4.0]), 0.2) == 1.0
    assert cvar(np.array([5.0, 1.0, 3.0, 2.0, 4.0]), 0.3) == 1.5
    estimate = aggregate_runs([1.0, 2.0, 3.0, 4.0, 100.0])
    assert estimate.value == 3.0  # the outlier is trimmed
    assert estimate.low <= 3.0 <= estimate.high
    paired = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    worst = bootstrap(paired, lambda b: b.mean(axis=1).min(axis=-1), rng=rng, reps=200)
    assert worst.value == 2.0 and worst.high <= 3.0
    with pytest.raises(ValueError, match="scores="):
        aggregate_runs([])
    with pytest.raises(ValueError, match="confidence=1"):
        aggregate_runs([1.0], confidence=1)


def test_a_grid_member_is_the_episodes_theta0_under_domain_randomisation():
    """A nature that draws θ_0 does not redraw a grid member's: the rows are as without it.

    The member was passed as the env's params and domain randomisation drew over it, so every
    grid row read the drawn pole (a long pole scored as the nominal one).
    """
    grid = {"length": [0.25, 1.5]}
    plain = evaluate_robustness(balance, CARTPOLE, grid=grid, episodes=3, **SHORT)
    drawn = DomainRandomisation({"length": Uniform(0.4, 0.6)})
    randomised = evaluate_robustness(
        balance, CARTPOLE, grid=grid, episodes=3, nature=drawn, **SHORT
    )
    rows = [c.returns for c in plain.conditions if c.group == "grid"]
    assert rows == [c.returns for c in randomised.conditions if c.group == "grid"]
    assert rows[1] != rows[0]  # the long pole falls: the member is played, not a draw


def test_numpy_grids_serialise_and_numpy_levels_are_numbers(tmp_path):
    """Grid values from np.arange / float32 np.linspace reach JSON as Python numbers.

    NumPy floats pass as alpha and confidence (np.float32(0.1) was refused as "not in (0, 1)").
    """
    report = evaluate_robustness(
        balance,
        CARTPOLE,
        grid={"masscart": np.arange(1, 3), "length": np.linspace(0.4, 0.6, 2, dtype=np.float32)},
        episodes=2,
        alpha=np.float32(0.25),
        confidence=np.float64(0.9),
        **SHORT,
    )
    data = json.loads(report.to_json())
    assert data["conditions"][1]["params"] == {"masscart": 1, "length": pytest.approx(0.4)}
    assert report.alpha == 0.25 and report.confidence == 0.9


def test_the_figure_leaves_the_callers_matplotlib_backend_alone(tmp_path):
    """plot() draws on a figure of its own: it switched the process's backend to Agg."""
    matplotlib = pytest.importorskip("matplotlib")
    before = matplotlib.get_backend()
    try:
        matplotlib.use("svg")
        report = evaluate_robustness(balance, CARTPOLE, episodes=1, **SHORT)
        report.plot(str(tmp_path / "robust.png"))
        assert matplotlib.get_backend() == "svg"
        assert (tmp_path / "robust.png").stat().st_size > 1000
    finally:
        matplotlib.use(before)


def test_grid_members_and_adversary_settings_are_refused_before_any_episode():
    """Bad grid names and values, confidence, seeds and AdversarySearch fields fail up front."""
    played = []

    def counting(obs):
        played.append(1)
        return balance(obs)

    for kwargs, error, text in (
        ({"grid": {"lenght": [0.5]}}, ValueError, "did you mean 'length'"),
        ({"grid": {"length": [-1.0]}}, ValueError, "length=-1.0 is outside"),
        ({"confidence": 1.5}, ValueError, "confidence=1.5"),
        ({"seed": 1.5}, ValueError, "seed=1.5"),
        ({"seed": -1}, ValueError, "seed=-1"),
    ):
        with pytest.raises(error, match=text):
            evaluate_robustness(counting, CARTPOLE, episodes=2, **kwargs, **SHORT)
    assert not played
    far = evaluate_robustness(balance, CARTPOLE, episodes=1, seed=2**32, **SHORT)
    assert far.seeds == (2**32,)  # episodes take any int >= 0 as their seed
    for kwargs, error, text in (
        ({"nature_reward": "bogus"}, ValueError, "nature_reward='bogus'"),
        ({"nature_action": "x"}, ValueError, "nature_action='x'"),
        ({"default_step": -1}, ValueError, "default_step=-1"),
        ({"nature_observes_state": "yes"}, TypeError, "nature_observes_state='yes'"),
        ({"args": "PPO"}, TypeError, "args='PPO' must be an ns_pz.learning.TrainArgs"),
    ):
        with pytest.raises(error, match=text):
            AdversarySearch(**kwargs)


def test_statistics_and_theta_sets_refuse_what_they_cannot_compute():
    """No silent number: CVaR's level, an empty IQM, zero resamples, seeds named."""
    values = np.array([1.0, 2.0, 3.0])
    assert cvar(values, 1) == 2.0  # the mean
    for alpha in (2, -1, 0, True):
        with pytest.raises(ValueError, match="alpha=.* must be a number in \\(0, 1\\]"):
            cvar(values, alpha)
    with pytest.raises(ValueError, match="needs at least one value"):
        interquartile_mean([])
    with pytest.raises(ValueError, match="reps=0"):
        aggregate_runs([1.0, 2.0], reps=0)
    with pytest.raises(ValueError, match="seed=-1"):
        aggregate_runs([1.0, 2.0], seed=-1)
    assert aggregate_runs([1.0, 2.0], seed=2**40).value == 1.5  # any int >= 0 seeds NumPy
    with pytest.raises(ValueError, match="confidence=np.float32"):
        aggregate_runs([1.0, 2.0], confidence=np.float32(1.5))
    assert aggregate_runs([1.0, 2.0, 3.0], confidence=np.float32(0.9)).value == 2.0
    lengths = {"length": Uniform(0.3, 3.0)}
    for seed in (None, -1, 1.5):
        with pytest.raises(ValueError, match=f"seed={seed!r}"):
            ThetaSet.sample(lengths, 4, seed=seed)
        with pytest.raises(ValueError, match=f"seed={seed!r}"):
            ThetaSet.sample(lengths, 4, seed=0).split(0.5, seed=seed)
