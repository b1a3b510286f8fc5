"""What the installed distribution contains: ns_pz and its subpackages, nothing at the top."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import ns_pz.agents
import ns_pz.envs
import pytest

import ns_pz


def installed_files() -> list[str]:
    """Files of the distribution next to the imported package (skip when run from a tree)."""
    site = Path(ns_pz.__file__).resolve().parents[1]
    infos = sorted(site.glob("ns_pz-*.dist-info"))
    if not infos:
        pytest.skip("ns_pz is imported from a source tree; the wheel layout is checked installed")
    return [str(path) for path in metadata.Distribution.at(infos[0]).files or []]


def test_envs_and_agents_install_under_ns_pz_only():
    """No top-level `envs` or `agents` lands in site-packages; they live under ns_pz."""
    files = installed_files()
    assert not [f for f in files if f.startswith(("envs/", "agents/"))]
    assert "ns_pz/envs/registry.py" in files and "ns_pz/agents/base.py" in files
    assert "ns_pz/compat/update_functions/distribution.py" in files
    assert "ns_pz/compat/wrappers/toy_text.py" in files and "ns_pz/compat/envs/Bridge.py" in files
    assert ns_pz.envs.__name__ == "ns_pz.envs" and ns_pz.agents.__name__ == "ns_pz.agents"


def test_console_script_is_declared():
    """The ns-pz command is an entry point of the distribution."""
    scripts = {ep.name for ep in metadata.entry_points(group="console_scripts")}
    assert "ns-pz" in scripts


CHECKOUT = Path(__file__).resolve().parents[1]
IMPORT_FROM_ROOT = (
    "import ns_pz, ns_pz.envs.registry, ns_pz.agents.search, ns_pz.agents.search.mcts\n"
    "import gymnasium\n"
    "gymnasium.make('ns_pz/FrozenLake-v0')\n"
    "print(ns_pz.__file__); print(ns_pz.envs.__file__); print(ns_pz.agents.search.__file__)\n"
)
WITHOUT_INSTALLED_NS_PZ = (
    # The checkout alone: drop the finder of an editable install, if any, before importing.
    "import sys\n"
    "sys.meta_path[:] = [\n"
    "    f for f in sys.meta_path if '__editable__' not in getattr(f, '__module__', '')\n"
    "]\n"
)


@pytest.mark.parametrize("installed", [True, False], ids=["as-installed", "checkout-only"])
def test_python_started_in_the_checkout_root_imports_the_whole_package(installed):
    """The checkout's ns_pz/ shadows the installed one there; envs/ and agents/ come with it."""
    if not (CHECKOUT / "ns_pz" / "__init__.py").is_file():
        pytest.skip("the tests do not run from a source checkout")
    code = IMPORT_FROM_ROOT if installed else WITHOUT_INSTALLED_NS_PZ + IMPORT_FROM_ROOT
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=CHECKOUT, check=False
    )
    assert out.returncode == 0, out.stderr
    package, envs, search = (Path(line) for line in out.stdout.split())
    assert package == CHECKOUT / "ns_pz" / "__init__.py"
    assert envs == CHECKOUT / "envs" / "__init__.py"
    assert search == CHECKOUT / "agents" / "search" / "__init__.py"


def test_source_tree_finder_ignores_an_installed_layout_and_foreign_folders(tmp_path):
    """Only a checkout (no envs/ inside ns_pz/, a pyproject mapping ns_pz.envs) is mapped."""
    from ns_pz import _source_tree

    installed = tmp_path / "site" / "ns_pz"
    (installed / "envs").mkdir(parents=True)
    (tmp_path / "site" / "envs").mkdir()
    (tmp_path / "site" / "envs" / "__init__.py").write_text("")
    assert _source_tree.checkout_mapping(installed) == {}  # an installed ns_pz has envs inside
    other = tmp_path / "other"
    (other / "ns_pz").mkdir(parents=True)
    (other / "envs").mkdir()
    (other / "envs" / "__init__.py").write_text("")
    (other / "pyproject.toml").write_text('[project]\nname = "something-else"\n')
    assert _source_tree.checkout_mapping(other / "ns_pz") == {}  # no ns_pz.envs mapping
    mapping = _source_tree.checkout_mapping(CHECKOUT / "ns_pz")
    assert mapping["ns_pz.envs"] == CHECKOUT / "envs"
    assert mapping["ns_pz.agents"] == CHECKOUT / "agents"
