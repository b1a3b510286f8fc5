"""NumPy's own BLAS routines, for compiled code that must compute NumPy's products bit for bit.

NumPy's wheels bundle OpenBLAS with 64-bit integer arguments (``scipy_openblas64_`` since NumPy
2.0, ``openblas64_`` before) and compute a float64 ``a @ b`` of contiguous matrices with its
``cblas_dgemm`` (its ``cblas_dgemv`` when ``a`` is a single row). A product the same routine
computes from the same arguments, under the same thread count, is the same bits, so compiled
code that calls these routines where NumPy would, with the arguments NumPy would pass, trains
the very network NumPy's products train: the Double DQN learner does so (:mod:`._mlp_kernels`),
without the thirty-odd NumPy calls, each about a microsecond, of every gradient step.

:func:`blas_routines` finds the two routines of the OpenBLAS NumPy loaded; None where there is
none (a NumPy built against MKL, Accelerate or a system BLAS): learners then keep NumPy's own
products. Whoever uses them checks, once per network shape and row count, that they give
NumPy's bits (the dispatch above is NumPy's code, not its documented behaviour).
"""

from __future__ import annotations

import ctypes
import functools
import os

import numpy as np
from threadpoolctl import threadpool_info

#: The symbols of ``cblas_dgemm`` and ``cblas_dgemv`` in the OpenBLAS builds NumPy's wheels
#: bundle: scipy-openblas64 (NumPy 2) and openblas64 (NumPy 1.26), both with 64-bit integers.
SYMBOLS = (
    ("scipy_cblas_dgemm64_", "scipy_cblas_dgemv64_"),
    ("cblas_dgemm64_", "cblas_dgemv64_"),
)


@functools.cache
def blas_routines() -> np.ndarray | None:
    """``[dgemm address, dgemv address]`` (int64) of the OpenBLAS NumPy loaded, or None.

    The library is the OpenBLAS that ``threadpoolctl`` finds loaded from NumPy's own folder
    (``numpy.libs`` beside the package, or ``numpy/.dylibs``), the one ``numpy.matmul`` calls.
    """
    home = os.path.dirname(os.path.realpath(np.__file__))
    folders = (home, os.path.realpath(os.path.join(home, os.pardir, "numpy.libs")))
    for library in threadpool_info():
        path = os.path.realpath(library.get("filepath") or "")
        if library.get("internal_api") != "openblas" or not path.startswith(folders):
            continue
        try:
            handle = ctypes.CDLL(path)  # already loaded: the same handle NumPy uses
        except OSError:
            return None
        for symbols in SYMBOLS:
            functions = [getattr(handle, symbol, None) for symbol in symbols]
            if all(function is not None for function in functions):
                addresses = [ctypes.cast(f, ctypes.c_void_p).value for f in functions]
                return np.array(addresses, dtype=np.int64)
        return None
    return None
