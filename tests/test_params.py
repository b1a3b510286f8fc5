"""θ as data: validation messages, immutability, derived quantities, projection, sizes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from ns_pz.envs.cartpole import CartPoleParams
from ns_pz.envs.frozen_lake import FrozenLakeParams

from ns_pz import ParamOutOfRange, UnknownParam
from ns_pz.params import Params, project_to_simplex, scalar, simplex


def test_defaults_are_gymnasium_constants():
    """CartPole defaults equal Gymnasium's CartPole-v1 constants."""
    theta = CartPoleParams()
    assert (theta.gravity, theta.masscart, theta.masspole) == (9.8, 1.0, 0.1)
    assert (theta.length, theta.force_mag, theta.tau) == (0.5, 10.0, 0.02)


def test_derived_quantities_follow_theta():
    """Total mass and pole mass-length are computed from θ, never stored."""
    theta = CartPoleParams().replace(masspole=0.3, length=2.0)
    assert theta.total_mass == pytest.approx(1.3)
    assert theta.polemass_length == pytest.approx(0.6)
    assert "total_mass" not in theta.names()


def test_theta_is_immutable():
    """Assigning a field of θ raises; replace returns a new value and leaves the old one."""
    theta = CartPoleParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        theta.masspole = 0.5  # type: ignore[misc]
    other = theta.replace(masspole=0.5)
    assert theta.masspole == 0.1 and other.masspole == 0.5


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"masspole": -0.2}, r"CartPoleParams.masspole=-0.2 is outside \[0.001, 1000.0\]"),
        ({"masspole": float("nan")}, r"masspole=nan is not finite"),
        ({"gravity": float("inf")}, r"gravity=inf is not finite"),
        ({"length": "long"}, r"length='long' is not a real number"),
        ({"tau": 0.0}, r"tau=0.0 is outside \[0.0001, 1.0\]"),
    ],
)
def test_invalid_scalars_are_refused_with_the_value_and_range(changes, match):
    """Each invalid scalar names the parameter, the value and what is allowed."""
    with pytest.raises(ParamOutOfRange, match=match):
        CartPoleParams().replace(**changes)


def test_unknown_parameter_suggests_close_names():
    """An unknown name is a ValueError that lists close matches."""
    with pytest.raises(UnknownParam, match=r"no parameter 'maspole' \(did you mean 'masspole'"):
        CartPoleParams().replace(maspole=0.2)
    with pytest.raises(ValueError, match="known: gravity, masscart"):
        CartPoleParams.from_mapping({"wind": 1.0})


@pytest.mark.parametrize(
    ("slip", "match"),
    [
        ((0.7, 0.1, 0.1), r"sums to 0.8999999999999999, not 1"),
        ((1.2, -0.1, -0.1), r"has an element outside \[0, 1\]"),
        ((0.5, 0.5), r"has 2 elements, expected 3"),
        ((float("nan"), 0.5, 0.5), r"is not finite"),
        ("abc", r"is not a sequence of 3 probabilities"),
    ],
)
def test_invalid_probability_vectors_are_refused(slip, match):
    """Off-simplex, negative, wrong-length, NaN and non-sequence slip vectors all raise."""
    with pytest.raises(ParamOutOfRange, match=match):
        FrozenLakeParams(slip=slip)


def test_vector_within_tolerance_is_accepted_and_stored_as_tuple():
    """A list summing to 1 within 1e-8 is accepted and canonicalised to a tuple of floats."""
    theta = FrozenLakeParams(slip=[0.7, 0.15, 0.15 + 5e-9])
    assert isinstance(theta.slip, tuple) and all(type(p) is float for p in theta.slip)


def test_flat_round_trip_and_bounds():
    """flat() follows flat_layout(); flat bounds follow the specs."""
    theta = CartPoleParams(masspole=0.3)
    for spec, start, stop in CartPoleParams.flat_layout():
        assert theta.flat()[start:stop].tolist() == [getattr(theta, spec.name)]
    assert FrozenLakeParams.flat_layout()[0][1:] == (0, 3)
    low, high = CartPoleParams.flat_bounds()
    assert low[0] == 0.0 and high[2] == 1e3


def test_change_sizes_use_total_variation_for_vectors():
    """Scalar sizes are |Δ|; vector sizes are W1 under the discrete metric (total variation)."""
    before = FrozenLakeParams(slip=(1.0, 0.0, 0.0))
    after = FrozenLakeParams(slip=(0.6, 0.2, 0.2))
    assert after.change_sizes(before) == (pytest.approx(0.4),)
    assert CartPoleParams(masspole=0.5).change_sizes(CartPoleParams()) == (
        0.0,
        0.0,
        pytest.approx(0.4),
        0.0,
        0.0,
        0.0,
    )


def test_projection_onto_bounds_and_simplex():
    """project() clips scalars, projects vectors onto the simplex and refuses NaN."""
    spec = CartPoleParams.spec("masspole")
    assert spec.project("C", -5.0) == 1e-3 and spec.project("C", 1e9) == 1e3
    slip = FrozenLakeParams.spec("slip")
    projected = slip.project("F", (2.0, 0.0, -1.0))
    assert projected == (1.0, 0.0, 0.0)
    with pytest.raises(ParamOutOfRange, match="NaN"):
        spec.project("C", math.nan)


def test_random_projections_always_land_on_the_simplex():
    """Property: projecting any finite vector yields a probability vector nearest to it."""
    rng = np.random.default_rng(0)
    for _ in range(500):
        vector = rng.normal(0, 2, size=rng.integers(2, 6))
        projected = np.array(project_to_simplex(vector))
        assert projected.min() >= 0 and abs(projected.sum() - 1) < 1e-12
        probe = rng.dirichlet(np.ones(len(vector)))
        assert np.linalg.norm(projected - vector) <= np.linalg.norm(probe - vector) + 1e-12


def test_random_valid_theta_never_fails_validation():
    """Property: θ drawn uniformly within bounds always constructs, and round-trips."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        values = {
            spec.name: float(rng.uniform(spec.low, spec.high)) for spec in CartPoleParams.specs()
        }
        theta = CartPoleParams(**values)
        assert theta.as_dict() == values


def test_projection_refuses_what_has_no_nearest_value_and_survives_huge_inputs():
    """Inf on an unbounded side and non-finite vectors are refused; huge vectors still project."""
    from ns_pz.params import ParamSpec

    free = ParamSpec("x", "scalar", 0.0)
    with pytest.raises(ParamOutOfRange, match="no nearest finite value"):
        free.project("P", math.inf)
    assert CartPoleParams.spec("gravity").project("C", math.inf) == 1e3  # bounded: clipped
    slip = FrozenLakeParams.spec("slip")
    assert slip.project("F", (1e17, 0.0, 0.0)) == (1.0, 0.0, 0.0)
    assert slip.project("F", (-1e300, 1e300, 0.0)) == (0.0, 1.0, 0.0)
    with pytest.raises(ParamOutOfRange, match="is not finite"):
        slip.project("F", (math.inf, 0.0, 0.0))


@pytest.mark.parametrize(
    ("low", "high", "low_open", "high_open"),
    [
        (0.0, 1.0, False, False),
        (0.0, math.inf, True, False),
        (-math.inf, math.inf, False, False),
        (0.0, 0.1, False, True),
        (-math.inf, 5.0, True, True),
        (1, 2, False, False),  # int bounds
    ],
)
def test_project_keeps_exactly_the_admissible_finite_floats(low, high, low_open, high_open):
    """project() returns a float as it is exactly when it is inside the bounds and finite."""
    from ns_pz.params import ParamSpec

    spec = ParamSpec("x", "scalar", 0.5, low, high, low_open, high_open)
    edges = [low, high, -low, -high, 0.0, -0.0, 0.5, 1.5, 1e308, -1e308, 5e-324]
    probes = [float(v) for v in edges if math.isfinite(v)]
    probes += [math.nextafter(v, d) for v in probes for d in (-math.inf, math.inf)]
    probes += [math.inf, -math.inf, math.nan]
    for value in probes:
        admissible = spec.contains(value) and math.isfinite(value)
        lo, hi = spec.finite_range
        assert (lo <= value <= hi) is admissible, value
        if admissible:
            assert spec.project("P", value) is value
        elif math.isfinite(value):  # moved inside
            assert spec.contains(spec.project("P", value))
            assert spec.project("P", value) != value


def test_total_variation_is_the_sum_of_the_differences_for_every_size():
    """The written-out distance of small vectors equals 0.5 * sum(|b - a|), bit for bit."""
    import operator

    from ns_pz.params import ParamSpec

    rng = np.random.default_rng(3)
    for size in range(2, 12):
        outcomes = tuple(str(i) for i in range(size))
        spec = ParamSpec("slip", "simplex", (1.0,) + (0.0,) * (size - 1), outcomes=outcomes)
        for _ in range(300):
            a = tuple(rng.dirichlet(np.ones(size)).tolist())
            b = tuple(rng.dirichlet(np.ones(size) * rng.uniform(0.01, 5)).tolist())
            assert spec.distance(a, b) == 0.5 * sum(map(abs, map(operator.sub, b, a)))
        for short, long in ((a[:-1], a), (a, a + (0.0,))):
            with pytest.raises(ValueError, match=f"two vectors of {size} elements"):
                spec.distance(short, long)


def test_theta_unpickled_in_a_fresh_process_works_on_the_change_path(tmp_path):
    """A θ that arrives pickled (e.g. in a worker) can be projected and evolved at once."""
    import pickle
    import subprocess
    import sys

    path = tmp_path / "theta.pkl"
    path.write_bytes(pickle.dumps(CartPoleParams(masspole=0.3)))
    code = (
        "import math, pickle, sys; from ns_pz.nature.constraints import admit, NatureConstraints;"
        f" theta = pickle.loads(open({str(path)!r}, 'rb').read());"
        " new, _ = admit(theta, {'masspole': 0.5}, NatureConstraints(), math.inf);"
        " print(new.masspole)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, check=True
    )
    assert out.stdout.strip() == "0.5"


@dataclasses.dataclass(frozen=True)
class _UnslottedParams(Params):
    """A user's θ declared without ``slots=True``: evolve_trusted falls back to setattr."""

    speed: float = scalar(1.0, low=0.0, high=10.0)
    mix: tuple[float, ...] = simplex((0.5, 0.5), outcomes=("a", "b"))


@pytest.mark.parametrize(
    ("theta", "changes"),
    [
        (CartPoleParams(), {"masspole": 0.2}),
        (CartPoleParams(), {"gravity": 9.0, "tau": 0.01}),
        (FrozenLakeParams(), {"slip": (0.5, 0.25, 0.25)}),
        (_UnslottedParams(), {"mix": (0.25, 0.75)}),
        (_UnslottedParams(), {}),
    ],
)
def test_evolve_trusted_changes_only_the_given_fields_and_leaves_theta_alone(
    theta: Params, changes: dict
) -> None:
    """The generated (slots) and the fallback (no slots) copy agree with ``replace``."""
    before = theta.as_dict()
    new = theta.evolve_trusted(changes)
    assert type(new) is type(theta)
    assert new.as_dict() == {**before, **changes}
    assert new == theta.replace(**changes)
    assert theta.as_dict() == before
    assert new is not theta
    generated = Params.layout_of(theta).evolve.__name__ == "evolve"
    assert generated is not isinstance(theta, _UnslottedParams)  # slots: the generated copy


def test_projection_makes_numpy_and_int_vectors_python_floats():
    """Nature's float32 or int vectors become Python floats on the simplex.

    A float32 proposal summed in float32 (1 + 1.5e-8 in float64) was admitted as it was: θ then
    held float32 elements, and a later replace() blamed the untouched parameter.
    """
    spec = FrozenLakeParams.spec("slip")
    proposal = tuple(np.array([0.5, 0.3, 0.2], np.float32))
    granted = spec.project("FrozenLakeParams", proposal)
    assert all(type(p) is float for p in granted)
    assert abs(math.fsum(granted) - 1.0) <= 1e-9
    theta = FrozenLakeParams().replace(slip=granted)
    assert theta.replace(slip=(1.0, 0.0, 0.0)).slip == (1.0, 0.0, 0.0)
    ints = spec.project("FrozenLakeParams", (1, 0, 0))
    assert ints == (1.0, 0.0, 0.0) and all(type(p) is float for p in ints)


def test_change_sizes_names_a_previous_of_another_class():
    """It raised AttributeError about a missing field of the other class."""
    with pytest.raises(TypeError, match="needs a CartPoleParams"):
        CartPoleParams().change_sizes(FrozenLakeParams())  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("declare", "match"),
    [
        (lambda: scalar(0.5, low=1.0, high=0.0), "empty or NaN range"),
        (lambda: scalar(0.5, low=math.nan), "empty or NaN range"),
        (lambda: scalar(0.0, low=0.0, high=0.0, high_open=True), "empty or NaN range"),
        (lambda: scalar(5.0, low=0.0, high=1.0), "outside the declared range \\[0.0, 1.0\\]"),
        (lambda: scalar(0.0, low=0.0, low_open=True), "outside the declared range \\(0.0"),
        (lambda: simplex((0.5, 0.6), outcomes=("a", "b")), "not a probability vector"),
        (lambda: simplex((), outcomes=()), "at least one"),
        (lambda: scalar(math.inf), "outside the declared range"),
    ],
)
def test_a_bad_declaration_is_refused_where_it_is_written(declare, match):
    """It was accepted, and the first θ failed with a message blaming the value."""
    with pytest.raises(ValueError, match=match):
        declare()


def test_a_simplex_takes_its_outcome_names_from_any_sequence():
    """An array of names (the emptiness test asked an array for its truth value)."""
    declared = simplex((0.5, 0.5), outcomes=np.array(["left", "right"]))
    assert declared.default == (0.5, 0.5)
