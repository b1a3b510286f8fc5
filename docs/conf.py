"""Sphinx configuration of the ns_pz documentation.

Build with ``sphinx-build -W --keep-going docs docs/_build/html`` (see the README). The family
pages and the API pages are generated from the code by ``_ext/ns_pz_docs.py``; the tutorials in
``tutorials/`` are executed by sphinx-gallery on every build.
"""

import logging
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
sys.path.insert(0, str(Path(__file__).parent / "_ext"))
# Tutorials run numba-compiled search; keep its cache inside the build, not in site-packages.
os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).parent / "_build" / "numba-cache"))



class _NoMystConfiguration(logging.Filter):
    """Drops MyST's dump of its whole parser configuration (a 1,000-character line per build)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "myst v%s:" not in str(record.msg)


logging.getLogger("sphinx.myst_parser.sphinx_ext.main").addFilter(_NoMystConfiguration())


def _mujoco_warning(message: str) -> None:
    """MuJoCo's warnings, less the deprecation of ``settotalmass``.

    Gymnasium's v5 model files set it, and MuJoCo says so at every compile (the family pages
    build every MuJoCo task); nothing these pages can change.
    """
    if "settotalmass" not in message:
        print(f"MuJoCo warning: {message}", file=sys.stderr)


try:
    import mujoco

    mujoco.set_mju_user_warning(_mujoco_warning)
except ImportError:  # without the mujoco extra there are no MuJoCo pages
    pass

project = "ns_pz"
author = "the ns_pz authors"
copyright = "the ns_pz authors"  # noqa: A001 - the name Sphinx reads

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",  # the Markdown pages (moved from the README) stay Markdown
    "sphinx_gallery.gen_gallery",
    "ns_pz_docs",
]

exclude_patterns = ["_build", "tutorials/README.rst", "**/GALLERY_HEADER.rst"]

# Google-style docstrings, as the code is written (ruff's pydocstyle convention = "google").
myst_enable_extensions = ["dollarmath"]
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# "Attributes:" sections as field lists, so dataclass fields documented by autodoc are not
# described twice.
napoleon_use_ivar = True
# Optional dependencies too heavy for the docs extra: autodoc (and the page generator) import
# the modules that need them with these names mocked.
autodoc_mock_imports = ["pyspiel"]
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "signature"
autodoc_inherit_docstrings = True
# Annotations that stay strings (imported under TYPE_CHECKING) and would match several aliases.
autodoc_type_aliases = {"State": "ns_pz.family.State"}
# "Type: State" in an Attributes section matches several families' ``State`` aliases; Sphinx links
# the first. Only that ambiguity is silenced ("ref.python"); a missing target still fails.
suppress_warnings = ["ref.python"]
autodoc_class_signature = "separated"

sphinx_gallery_conf = {
    "examples_dirs": ["tutorials"],
    "gallery_dirs": ["generated_tutorials"],
    "filename_pattern": r".*\.py$",  # execute every tutorial, not only plot_*.py
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "abort_on_example_error": True,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "reset_modules": ("matplotlib",),
    "show_memory": False,
}

html_theme = "furo"
html_title = "ns_pz"
html_static_path: list[str] = []
