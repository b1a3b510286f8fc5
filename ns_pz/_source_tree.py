"""Importing ns_pz from a source checkout: ns_pz.envs is envs/, ns_pz.agents is agents/.

The repository keeps ``envs/`` and ``agents/`` beside ``ns_pz/``; pyproject.toml's setuptools
``package-dir`` installs them as ``ns_pz.envs`` and ``ns_pz.agents`` (a wheel puts them inside
``site-packages/ns_pz/``; an editable install adds a finder with the same mapping). A Python
started in the checkout root (a REPL, a notebook, ``python -m pytest``) imports the checkout's
``ns_pz/`` first, whatever is installed, and that folder has no ``envs``. :func:`install` then
adds, ahead of the other finders, a meta-path finder that applies the checkout's own
``package-dir`` mapping, read from its pyproject.toml, so the checkout imports as a whole.
``ns_pz/__init__.py`` imports this module first; importing it installs the finder.

A finder rather than an extended ``ns_pz.__path__``: appending the checkout root to
``__path__`` would make every folder there a subpackage (``ns_pz.tests``, ``ns_pz.benchmarks``,
``ns_pz.ns_pz``) and make ``pkgutil.walk_packages(ns_pz.__path__)`` walk the whole checkout,
while the finder resolves exactly the names pyproject.toml maps, as setuptools' editable finder
does. It is only installed when this very ``ns_pz/`` sits in a checkout: no ``envs`` inside it
(an installed ``ns_pz`` always has one) and a pyproject.toml beside it that maps
``ns_pz.envs``; so an unrelated ``envs`` package next to an installed ns_pz is never used.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
import tomllib
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from pathlib import Path
from types import ModuleType

_PACKAGE = "ns_pz"


class SourceTreeFinder(importlib.abc.MetaPathFinder):
    """Finds the packages of a checkout's ``package-dir`` mapping (a ``sys.meta_path`` finder).

    Args:
        mapping: Package name (``"ns_pz.envs"``) to its folder.
    """

    def __init__(self, mapping: dict[str, Path]) -> None:
        self.mapping = mapping

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        """The spec of ``fullname`` if the mapping names it (its submodules load normally)."""
        folder = self.mapping.get(fullname)
        if folder is None:
            return None
        return importlib.util.spec_from_file_location(
            fullname, folder / "__init__.py", submodule_search_locations=[str(folder)]
        )


def checkout_mapping(package_dir: Path) -> dict[str, Path]:
    """The ``package-dir`` mapping of the checkout holding ``package_dir``, or ``{}``.

    Empty unless ``package_dir`` is the ``ns_pz`` folder of a checkout: it has no ``envs``
    inside, and the pyproject.toml beside it maps ``ns_pz.envs``. Only packages below ``ns_pz``
    whose folder exists are returned.
    """
    pyproject = package_dir.parent / "pyproject.toml"
    if (package_dir / "envs").exists() or not pyproject.is_file():
        return {}
    try:
        config = tomllib.loads(pyproject.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return {}
    dirs = config.get("tool", {}).get("setuptools", {}).get("package-dir", {})
    if not isinstance(dirs, dict) or f"{_PACKAGE}.envs" not in dirs:
        return {}
    mapping = {}
    for name, folder in dirs.items():
        located = package_dir.parent / str(folder)
        if str(name).startswith(f"{_PACKAGE}.") and (located / "__init__.py").is_file():
            mapping[str(name)] = located
    return mapping


def install(package_dir: Path | None = None) -> None:
    """Add a :class:`SourceTreeFinder` for ``package_dir``'s checkout, once; else do nothing.

    Args:
        package_dir: The ``ns_pz`` folder (default: the one holding this module).
    """
    if any(isinstance(finder, SourceTreeFinder) for finder in sys.meta_path):
        return
    mapping = checkout_mapping(package_dir or Path(__file__).resolve().parent)
    if mapping:
        # first, before an editable install's finder: that one maps ns_pz.envs and
        # ns_pz.agents to the folders of the checkout it was installed from, which may be
        # another checkout than this one (a second worktree sharing one venv)
        sys.meta_path.insert(0, SourceTreeFinder(mapping))


install()
