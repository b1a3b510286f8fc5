"""NumPy's own BLAS routines, for compiled code that must compute NumPy's products bit for bit.

NumPy's wheels bundle OpenBLAS as ``scipy_openblas64_`` (64-bit integer arguments) and compute a
float64 ``a @ b`` of contiguous matrices with its ``cblas_dgemm`` (its ``cblas_dgemv`` when ``a``
is a single row). A product the same routine computes from the same arguments, under the same
thread count, is the same bits, so compiled code that calls these routines where NumPy would,
with the arguments NumPy would pass, trains the very network NumPy's products train: the Double
DQN learner does so (:mod:`._mlp_kernels`), without the thirty-odd NumPy calls, each about a
microsecond, of every gradient step.

:func:`blas_routines` finds the two routines of the OpenBLAS NumPy loaded; None where there is
none (a NumPy built against MKL, Accelerate or a system BLAS): learners then keep NumPy's own
products. Whoever uses them checks, once per network shape, that they give NumPy's bits (the
dispatch above is NumPy's code, not its documented behaviour).
"""

from __future__ import annotations

import ctypes
import functools
import os

import numpy as np
from threadpoolctl import threadpool_info

#: The symbols of ``cblas_dgemm`` and ``cblas_dgemv`` in the scipy-openblas64 build NumPy bundles.
SYMBOLS = ("scipy_cblas_dgemm64_", "scipy_cblas_dgemv64_")


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
            functions = [getattr(handle, symbol) for symbol in SYMBOLS]
        except (OSError, AttributeError):
            return None
        addresses = [ctypes.cast(function, ctypes.c_void_p).value for function in functions]
        return np.array(addresses, dtype=np.int64)
    return None
