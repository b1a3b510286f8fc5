"""numpy's PCG64 drawn inline by compiled code (agents/search/_pcg64.py)."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.agents.search import uct_tree
from ns_pz.agents.search.compiled import numba_available
from ns_pz.agents.search.table_model import OutcomeTableModel

import ns_pz

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba (the fast extra) missing")


@pytest.fixture(scope="module")
def pcg64():
    """The module (it imports numba)."""
    from ns_pz.agents.search import _pcg64

    return _pcg64


@pytest.fixture(scope="module")
def kernels():
    """Compiled helpers that draw as the search kernels do, from whatever they are given."""
    import numba

    @numba.njit
    def draws(rng, count):
        out = np.empty(count)
        for i in range(count):
            out[i] = rng.random()
        return out

    @numba.njit
    def alternate(first, second, count):
        out = np.empty(count)
        for i in range(count):
            out[i] = first.random() if i % 3 else second.random()
        return out

    return draws, alternate


def _generators(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    return np.random.default_rng(seed), np.random.default_rng(seed)


@pytest.mark.parametrize("seed", [0, 1, 2**63 + 12345])
def test_inline_draws_are_the_generators_and_leave_its_state(pcg64, kernels, seed):
    """Bit-equal draws; afterwards the Generator goes on (any method) from the same state."""
    draws, _ = kernels
    inline, reference = _generators(seed)
    # a buffered 32-bit half (has_uint32) must survive: random() never reads or clears it
    inline.integers(0, 7, size=3, dtype=np.int32)
    reference.integers(0, 7, size=3, dtype=np.int32)
    (stream,) = pcg64.inline_streams(inline)
    assert isinstance(stream, pcg64.PCG64Stream)
    np.testing.assert_array_equal(draws(stream, 5000), draws(reference, 5000))
    assert inline.bit_generator.state == reference.bit_generator.state
    assert (
        inline.integers(0, 7, size=5, dtype=np.int32).tolist()
        == reference.integers(0, 7, size=5, dtype=np.int32).tolist()
    )
    np.testing.assert_array_equal(inline.normal(size=4), reference.normal(size=4))


def test_one_generator_given_twice_interleaves_as_the_generator(pcg64, kernels):
    """Two streams on one Generator share its state: draws interleave, none is repeated."""
    _, alternate = kernels
    inline, reference = _generators(7)
    first, second = pcg64.inline_streams(inline, inline)
    np.testing.assert_array_equal(alternate(first, second, 301), reference.random(301))
    assert inline.bit_generator.state == reference.bit_generator.state


def test_other_generators_and_objects_pass_through_unchanged(pcg64):
    """Other bit generators (their steps differ) and non-generators are handed back."""
    others = (
        np.random.Generator(np.random.MT19937(3)),
        np.random.Generator(np.random.PCG64DXSM(3)),
        np.random.Generator(np.random.Philox(3)),
        None,
    )
    assert pcg64.inline_streams(*others) == others
    assert pcg64.inline_draws_match()


def test_a_state_found_outside_the_bit_generator_is_not_read(pcg64, monkeypatch):
    """The pointer and the state it points to must both lie within the bit generator itself."""
    bit_generator = np.random.PCG64(1)
    start, end = pcg64._object_span(bit_generator)
    holder = bit_generator.ctypes.state_address
    state = pcg64.state_address(bit_generator)
    assert state is not None and start <= holder < state < end
    spans = {
        "the object ends before the pointer": (start, holder),
        "the object ends inside the state": (start, state + 16),
        "the object starts after the pointer": (holder + 1, end),
    }
    for why, span in spans.items():
        monkeypatch.setattr(pcg64, "_object_span", lambda obj, span=span: span)
        assert pcg64.state_address(bit_generator) is None, why
        generator = np.random.Generator(bit_generator)
        with pytest.raises(ValueError, match="is not where PCG64's is"):
            pcg64.PCG64Stream(generator)
        assert pcg64.inline_streams(generator) == (generator,), why


def test_a_stream_is_only_built_on_a_generator_on_pcg64(pcg64):
    """Other generators are refused by name; in Python a stream draws the generator's numbers."""
    for other in (np.random.Generator(np.random.MT19937(3)), np.random.PCG64(3), 0.5):
        with pytest.raises(ValueError, match="is not a Generator on numpy's PCG64"):
            pcg64.PCG64Stream(other)
    inline, reference = _generators(9)
    stream = pcg64.PCG64Stream(inline)
    assert [stream.random() for _ in range(3)] == reference.random(3).tolist()
    with pytest.raises(AttributeError):
        stream.address = 0  # type: ignore[misc]  # read-only: compiled code writes there


def test_a_failed_check_hands_the_generators_back(pcg64, monkeypatch):
    """Where the inline PCG64 is not this numpy's, the kernels draw through the Generator."""
    monkeypatch.setattr(pcg64, "inline_draws_match", lambda: False)
    generator = np.random.default_rng(0)
    assert pcg64.inline_streams(generator) == (generator,)


def test_a_compiled_search_leaves_both_generators_as_the_python_search_does(pcg64):
    """The model's and the search's generators end in the same state on both paths."""
    assert pcg64.inline_draws_match()  # so the compiled search draws inline
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    env.reset(seed=0)
    outcomes = env.planning_model().outcomes
    assert ((outcomes.probs > 0) & (outcomes.probs < 1)).any()  # slippery: the model draws
    states = {}
    for backend in ("python", "compiled"):
        model_rng, search_rng = _generators(5)
        model = OutcomeTableModel(outcomes, 0, model_rng)
        tree = uct_tree(model, 0, search_rng, iterations=60, depth=30, backend=backend)
        states[backend] = (
            model_rng.bit_generator.state,
            search_rng.bit_generator.state,
            tree.visits.tolist(),
            tree.simulated_steps,
        )
    assert states["python"] == states["compiled"]
