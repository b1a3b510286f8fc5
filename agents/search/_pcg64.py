"""numpy's PCG64 drawn inline in compiled code: the same numbers as ``Generator.random()``.

numba compiles ``rng.random()`` on a ``numpy.random.Generator`` to a call through the bit
generator's function pointer, which no compiler can inline: about 3.9 ns a draw on the
development machine, and a search draws once or twice per simulated step. A
:class:`PCG64Stream` stands for a Generator whose bit generator is numpy's ``PCG64``, and
compiled code's ``stream.random()`` performs that generator's own step in place: PCG64's 128-bit
multiply-add on the state, its XSL-RR output, and numpy's conversion to a double (the top 53
bits times 2**-53), reading and writing the state where the generator keeps it (1.6 ns a draw).
So the generator ends where it would have, and goes on from there in Python as if it had drawn
every number itself.

The state's address and layout (two 128-bit integers, state then increment, low half first)
are numpy's internals, so the state is read only where it lies within the bit generator
object's own memory (:func:`state_address`), and :func:`inline_streams` checks once per process
that the inline draws equal numba's draws on the Generator, and that the Generator then
continues from the same state; where either fails, it hands the generators back unchanged (the
kernels draw through them as before). Only ``random()`` exists on a stream: the kernels and
the family steps registered with :func:`ns_pz.agents.search._kernels.register_step` draw
nothing else. As for a registered step, numba's cache of the kernels does not notice an edit
here: after changing :func:`_next_double`, delete the cache folder
(:mod:`~ns_pz.agents.search.numba_cache`).

Imported with the kernels (it needs numba), never by ``import ns_pz``.
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

import numba
import numpy as np
from llvmlite import ir
from ns_pz.agents.search import numba_cache
from numba.core import cgutils, types
from numba.extending import (
    NativeValue,
    intrinsic,
    make_attribute_wrapper,
    models,
    overload_method,
    register_model,
    typeof_impl,
    unbox,
)

numba_cache.install()  # before the first cache=True below: caches go to a user folder

_MULTIPLIER = (2549297995355413924 << 64) + 4865540595714422341
"""PCG64's 128-bit LCG multiplier (the PCG family's default for 128-bit state)."""
_TO_UNIT = 1.0 / 9007199254740992.0
"""2**-53: numpy's double from the top 53 bits of a 64-bit draw."""
_STATE_BYTES = 32
"""The state and the increment, two 128-bit integers."""


class PCG64Stream:
    """A ``numpy.random.Generator`` on ``PCG64``, as compiled code draws from it inline.

    :func:`inline_streams` builds these once it has checked that this numpy's PCG64 is the one
    drawn inline. A stream keeps the generator (whose memory holds the state) alive; in Python
    (numba's JIT disabled) its ``random()`` is the generator's.

    Raises:
        ValueError: ``generator`` is not on numpy's ``PCG64``, or its state is not where
            :func:`state_address` looks for it.
    """

    __slots__ = ("_address", "_generator")

    def __init__(self, generator: np.random.Generator) -> None:
        bit_generator = getattr(generator, "bit_generator", None)
        if not isinstance(generator, np.random.Generator) or type(bit_generator) is not (
            np.random.PCG64
        ):
            raise ValueError(f"generator={generator!r} is not a Generator on numpy's PCG64")
        address = state_address(bit_generator)
        if address is None:
            raise ValueError(f"the state of {bit_generator!r} is not where PCG64's is")
        self._generator = generator
        self._address = address

    @property
    def generator(self) -> np.random.Generator:
        """The Generator drawn from."""
        return self._generator

    @property
    def address(self) -> int:
        """Where its bit generator keeps the 128-bit state and increment."""
        return self._address

    def random(self) -> float:
        """The generator's next draw (compiled code draws inline instead)."""
        return float(self._generator.random())

    def __repr__(self) -> str:
        return f"PCG64Stream({self._generator!r})"


def state_address(bit_generator: Any) -> int | None:
    """Where ``bit_generator`` (numpy's ``PCG64``) keeps its state, or None if not found.

    numpy's PCG64 holds a pointer to its state (first field of the struct at
    ``ctypes.state_address``), and the state inside the bit generator object itself. Both are
    checked to lie within the object's own memory (:func:`_object_span`) before anything is
    read from them, so another layout is refused rather than read.
    """
    start, end = _object_span(bit_generator)
    holder = bit_generator.ctypes.state_address
    if not start <= holder <= end - ctypes.sizeof(ctypes.c_void_p):
        return None
    address = ctypes.c_void_p.from_address(holder).value
    if address is None or not start <= address <= end - _STATE_BYTES:
        return None
    return address


def _object_span(obj: Any) -> tuple[int, int]:
    """Where ``obj``'s own fields lie: its address (CPython's ``id``) plus its type's size."""
    return id(obj), id(obj) + type(obj).__basicsize__


class PCG64StreamType(types.Type):
    """numba's type of a :class:`PCG64Stream`: the address of the state, with ``random()``."""

    def __init__(self) -> None:
        super().__init__(name="PCG64Stream")


pcg64_stream = PCG64StreamType()


@typeof_impl.register(PCG64Stream)
def _typeof_stream(value: PCG64Stream, context: Any) -> PCG64StreamType:
    return pcg64_stream


@register_model(PCG64StreamType)
class _StreamModel(models.StructModel):
    def __init__(self, dmm: Any, fe_type: PCG64StreamType) -> None:
        super().__init__(dmm, fe_type, [("address", types.uintp)])


make_attribute_wrapper(PCG64StreamType, "address", "address")


@unbox(PCG64StreamType)
def _unbox_stream(typ: PCG64StreamType, obj: Any, c: Any) -> NativeValue:
    address = c.pyapi.object_getattr_string(obj, "address")
    native = c.unbox(types.uintp, address)
    c.pyapi.decref(address)
    stream = cgutils.create_struct_proxy(typ)(c.context, c.builder)
    stream.address = native.value
    return NativeValue(stream._getvalue(), is_error=native.is_error)


@intrinsic
def _next_double(typingctx: Any, address: Any) -> Any:
    """One PCG64 step on the state at ``address``, as numpy's ``next_double``."""
    signature = types.float64(address)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        i64 = ir.IntType(64)
        i128 = ir.IntType(128)
        words = builder.inttoptr(args[0], i64.as_pointer())
        slots = [builder.gep(words, [ir.Constant(i64, k)]) for k in range(4)]
        low, high, inc_low, inc_high = (builder.load(slot) for slot in slots)

        def wide(lo: Any, hi: Any) -> Any:
            shifted = builder.shl(builder.zext(hi, i128), ir.Constant(i128, 64))
            return builder.or_(builder.zext(lo, i128), shifted)

        state = builder.mul(wide(low, high), ir.Constant(i128, _MULTIPLIER))
        state = builder.add(state, wide(inc_low, inc_high))
        low = builder.trunc(state, i64)
        high = builder.trunc(builder.lshr(state, ir.Constant(i128, 64)), i64)
        builder.store(low, slots[0])
        builder.store(high, slots[1])
        mixed = builder.xor(high, low)  # XSL-RR: xor the halves, rotate by the top 6 bits
        turn = builder.lshr(high, ir.Constant(i64, 58))
        back = builder.and_(builder.neg(turn), ir.Constant(i64, 63))
        output = builder.or_(builder.lshr(mixed, turn), builder.shl(mixed, back))
        top = builder.uitofp(builder.lshr(output, ir.Constant(i64, 11)), ir.DoubleType())
        return builder.fmul(top, ir.Constant(ir.DoubleType(), _TO_UNIT))

    return signature, codegen


@overload_method(PCG64StreamType, "random", inline="always", jit_options={"cache": True})  # type: ignore[call-arg]
def _stream_random(stream: Any) -> Any:
    def impl(stream: Any) -> float:  # pragma: no cover
        return _next_double(stream.address)  # type: ignore[call-arg]  # typed by numba

    return impl


@numba.njit(cache=True)
def _draws(rng, count):  # type: ignore[no-untyped-def]  # pragma: no cover
    """``count`` draws of ``rng.random()`` in compiled code."""
    out = np.empty(count)
    for i in range(count):
        out[i] = rng.random()
    return out


@functools.cache
def inline_draws_match() -> bool:
    """Whether this numpy's PCG64, drawn inline, gives numba's draws and leaves its state.

    Checked once per process on two generators from one seed: the state as read at its address
    against the Generator's own account of it, then 1,000 draws through a stream and through
    the Generator in compiled code, then one more of each in Python.
    """
    inline = np.random.default_rng(20261128)
    reference = np.random.default_rng(20261128)
    try:
        stream = PCG64Stream(inline)
    except ValueError:
        return False
    words = (ctypes.c_uint64 * 4).from_address(stream.address)
    told = inline.bit_generator.state["state"]
    if (words[0] | words[1] << 64, words[2] | words[3] << 64) != (told["state"], told["inc"]):
        return False
    same = np.array_equal(_draws(stream, 1000), _draws(reference, 1000))
    return bool(same and inline.random() == reference.random())


def inline_streams(*generators: Any) -> tuple[Any, ...]:
    """``generators``, each on numpy's ``PCG64`` as a :class:`PCG64Stream`, the rest unchanged.

    Unchanged too when :func:`inline_draws_match` fails. The same Generator twice gives two
    streams on the same state, so their draws interleave as the Generator's would.
    """
    if not inline_draws_match():
        return generators
    return tuple(_stream_or_itself(g) for g in generators)


def _stream_or_itself(generator: Any) -> Any:
    try:
        return PCG64Stream(generator)
    except ValueError:
        return generator
