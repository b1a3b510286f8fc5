"""What the installed distribution contains: ns_pz and its subpackages, nothing at the top."""

from __future__ import annotations

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
