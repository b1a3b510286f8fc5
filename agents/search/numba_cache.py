"""Where numba caches ns_pz's compiled kernels: a user cache folder, never the package itself.

Numba's default for ``cache=True`` writes beside the source, into ``__pycache__`` of the package
folder. For an installed ns_pz that is ``site-packages/ns_pz/...``: pip does not know those files,
so they survive ``pip uninstall``, and the folder they keep alive then imports as an empty
namespace package that hides a later (editable) install of ns_pz.

:func:`install` puts a cache locator in front of numba's own that takes every function defined
in ns_pz's folders (``ns_pz``, ``ns_pz.envs``, ``ns_pz.agents``, wherever they are) and caches
it in :func:`cache_dir`; functions of other packages keep numba's usual locations, so nothing
changes for a user's own ``cache=True`` code (a process-wide ``numba.config.CACHE_DIR`` would
move theirs too). The locator lists are numba internals (``CacheImpl`` and
``UserProvidedCacheLocator`` since 0.68, underscored before); on a numba without them the folder
is set as ``numba.config.CACHE_DIR``, numba's documented setting, unless the user set one.

The folder is, in order: ``$NS_PZ_CACHE_DIR/numba``; numba's own ``NUMBA_CACHE_DIR`` if set
(numba then places the files, as it would for any package); the platform's user cache folder
(``$XDG_CACHE_HOME/ns_pz/numba``, by default ``~/.cache/ns_pz/numba`` on Linux). Each source
folder gets its own subfolder (numba's path hash), so several installs or checkouts never share
machine code, and numba re-checks each source file's stamp before loading: editing
``_kernels.py`` recompiles. After editing a compiled step in another module, delete the folder.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import ns_pz.agents
import ns_pz.envs
from numba.core import caching, config
from numba.misc.appdirs import AppDirs

import ns_pz

ENV_VAR = "NS_PZ_CACHE_DIR"
"""Environment variable naming the root of ns_pz's caches (numba's go in its ``numba/``)."""


def cache_dir() -> Path | None:
    """The folder for ns_pz's compiled code, or None when ``NUMBA_CACHE_DIR`` decides.

    See the module docstring for the order in which it is chosen.
    """
    root = os.environ.get(ENV_VAR)
    if root:
        return Path(root).expanduser() / "numba"
    if getattr(config, "CACHE_DIR", ""):  # NUMBA_CACHE_DIR, read by numba's config
        return None
    return Path(AppDirs(appname="ns_pz", appauthor=False).user_cache_dir) / "numba"


def package_dirs() -> tuple[Path, ...]:
    """The folders whose functions are ns_pz's (the installed or checked-out sources)."""
    return tuple(Path(module.__file__ or "").resolve().parent for module in _PACKAGES)


_PACKAGES = (ns_pz, ns_pz.envs, ns_pz.agents)
_BASE: Any = getattr(caching, "UserProvidedCacheLocator", None) or getattr(
    caching, "_UserProvidedCacheLocator", None
)
_IMPL: Any = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)


def _is_ours(py_file: str) -> bool:
    path = Path(py_file).resolve()
    return any(path.is_relative_to(folder) for folder in package_dirs())


if _BASE is not None:

    class NSPZCacheLocator(_BASE):  # type: ignore[misc,valid-type]
        """Numba cache locator for ns_pz's functions: :func:`cache_dir`, per source folder."""

        def __init__(self, py_func: Any, py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            folder = cache_dir()
            assert folder is not None  # from_function only builds one when there is a folder
            # resolved: where a link points now (bench estimate's temporary cache links the
            # user's folder in), not a path through a link that is gone by the next compile
            self._cache_path = str(folder.resolve() / self.get_suitable_cache_subpath(py_file))

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            """A locator for ``py_func`` if ns_pz defines it and ns_pz picks the folder."""
            if cache_dir() is None or not os.path.exists(py_file) or not _is_ours(py_file):
                return None
            # The source-file mixin's check: the folder can be made and written, else None
            # (numba then tries its next locator).
            return super(_BASE, cls).from_function(py_func, py_file)


def install() -> None:
    """Route ns_pz's numba caches to :func:`cache_dir` (idempotent; before any ``njit``)."""
    if _BASE is not None and _IMPL is not None:
        locators = _IMPL._locator_classes
        if NSPZCacheLocator not in locators:
            locators.insert(0, NSPZCacheLocator)
        return
    folder = cache_dir()  # pragma: no cover - numba without the locator classes
    if folder is not None:  # pragma: no cover
        config.CACHE_DIR = str(folder)  # type: ignore[attr-defined]
