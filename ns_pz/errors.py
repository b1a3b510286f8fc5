"""Exceptions raised by ns_pz.

Every exception names the offending value and what is allowed. They subclass the built-in
exception a caller would naturally catch (``ValueError`` for bad values, ``TypeError`` for bad
types, ``RuntimeError`` for calls in the wrong state), so ``except ValueError`` keeps working.
"""

from __future__ import annotations


class NSPZError(Exception):
    """Base class of every exception ns_pz raises on purpose."""


class ParamError(NSPZError, ValueError):
    """A parameter set θ is invalid: unknown name, non-finite, out of bounds, off the simplex."""


class UnknownParam(ParamError):
    """A parameter name that the parameter set does not declare."""


class ParamOutOfRange(ParamError):
    """A parameter value outside its declared bounds, or a probability vector off the simplex."""


class UnknownEnvironment(NSPZError, ValueError):
    """An environment id that is not registered."""


class ResetNeeded(NSPZError, RuntimeError):
    """A call that needs a running episode: before the first reset, or after the episode ended."""


class MissingExtra(NSPZError, ImportError):
    """An optional dependency is not installed; the message names the ``ns_pz`` extra to install."""
