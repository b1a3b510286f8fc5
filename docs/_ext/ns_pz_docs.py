"""Sphinx extension: pages generated from the code; a check that every public name is documented.

At ``builder-inited`` it writes (into ``docs/families/`` and ``docs/api/``, both git-ignored):

* one page per environment family, read from the registry (:func:`ns_pz.registered_envs`,
  :func:`ns_pz.spec`) and the family's parameter specs (:meth:`ns_pz.Params.specs`): θ with kind,
  unit, bounds and default, the spaces, the planning model, the registered ids and options.
  Registering a family is what adds its page.
* one API page per public module, grouped by the layers of the design, with
  ``automodule :members:``. A module that no layer rule places fails the build.

At ``env-check-consistency`` it warns (an error under ``-W``) for every public name that has no
docstring or no entry in the built documentation. :func:`public_names` defines "public".
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment
from sphinx.ext.autodoc.mock import mock
from sphinx.util import logging

logger = logging.getLogger(__name__)

# The package's layers (imports point down only), in reading order: (title, blurb, module-name
# rules). A module belongs to the first layer with a rule equal to its name or a prefix of it
# followed by a dot.
LAYERS: list[tuple[str, str, tuple[str, ...]]] = [
    (
        "θ: parameter sets",
        "Immutable, validated parameter values and their errors (and leaf utilities).",
        (
            "ns_pz.params",
            "ns_pz.errors",
            "ns_pz.checks",
            "ns_pz.files",
            "ns_pz.workers",
            "ns_pz.extras",
        ),
    ),
    (
        "Nature",
        "Who sets θ: schedules, update rules, constraints, learned natures.",
        ("ns_pz.nature",),
    ),
    ("Monitor", "Who decides what the agent is told.", ("ns_pz.monitor",)),
    (
        "The game",
        "The one cycle, the PettingZoo AEC game, and what it is built from.",
        (
            "ns_pz.process",
            "ns_pz.game",
            "ns_pz.observations",
            "ns_pz.regret",
            "ns_pz.family",
            "ns_pz.states",
        ),
    ),
    (
        "The view",
        "The Gymnasium environment that collapses the game, and rendering.",
        ("ns_pz.views", "ns_pz.rendering", "ns_pz.vector"),
    ),
    (
        "Learning",
        "Any seat as a single-agent Gymnasium env; training with SB3; robust RL and its "
        "evaluation.",
        (
            "ns_pz.seats",
            "ns_pz.seat_policies",
            "ns_pz.learning",
            "ns_pz.learn",
            "ns_pz.sb3_vec",
            "ns_pz.rllib",
        ),
    ),
    ("Planning", "Stationary models that search agents simulate.", ("ns_pz.planning",)),
    ("Environments", "The families and the registry (installed as ns_pz.envs).", ("ns_pz.envs",)),
    (
        "Exact tools",
        "Exact optima, references and robust policies for tabular families.",
        ("ns_pz.agents.exact",),
    ),
    (
        "Agents",
        "Decision agents, search and the agent catalog (installed as ns_pz.agents).",
        ("ns_pz.agents",),
    ),
    (
        "Experiments",
        "Benchmark specs, trials, runner, backends and reports.",
        ("ns_pz.experiments",),
    ),
    ("Compat", "NS-Gym's API over the ns_pz core.", ("ns_pz.compat",)),
    (
        "Package, testing and command line",
        "The top-level package, the conformance suite, the CLI.",
        ("ns_pz", "ns_pz.testing", "ns_pz.cli"),
    ),
]


def public_modules() -> list[str]:
    """Every module of ns_pz whose dotted name has no part starting with ``_``.

    Modules that refuse to be imported by design (``ns_pz.compat``'s stand-ins for NS-Gym
    modules ns_pz does not provide raise an ``ImportError`` of their own) are left out; a
    missing dependency (``ModuleNotFoundError`` naming a module) fails the build instead.
    """
    names = ["ns_pz", "ns_pz.envs", "ns_pz.agents"]
    # ns_pz.envs and ns_pz.agents are installed from other directories (package-dir), so an
    # editable install's ns_pz.__path__ does not reach them: walk the three roots.
    infos = [
        info
        for root in names
        for info in pkgutil.walk_packages(importlib.import_module(root).__path__, root + ".")
    ]
    for info in infos:
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        try:
            importlib.import_module(info.name)
        except ImportError as error:
            if error.name is not None:
                raise
            continue
        names.append(info.name)
    return sorted(set(names))


def layer_of(module: str) -> int | None:
    """Index into :data:`LAYERS` of the layer that holds ``module`` (exact names win)."""
    for index, (_, _, rules) in enumerate(LAYERS):
        if module in rules:
            return index
    for index, (_, _, rules) in enumerate(LAYERS):
        if any(module.startswith(rule + ".") for rule in rules if rule != "ns_pz"):
            return index
    return None


def _assigned_names(module: types.ModuleType) -> list[str]:
    """Names assigned at the top level of the module's source (constants, aliases)."""
    try:
        tree = ast.parse(inspect.getsource(module))
    except (OSError, TypeError):
        return []
    names: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.Assign):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return names


def public_names(module_name: str) -> Iterator[tuple[str, str, Any]]:
    """The public names of a module, as ``(qualified name, defining module, object)``.

    A module with ``__all__`` exports exactly those names, wherever they are defined (each is
    documented once, at the module that defines it). Otherwise its public names are the classes
    and functions it defines and the constants it assigns, none starting with ``_``. Of a public
    class, its public methods and properties defined in the class body count too.
    """
    module = importlib.import_module(module_name)
    exported = getattr(module, "__all__", None)
    if exported is None:
        candidates = [
            n
            for n, obj in vars(module).items()
            if (inspect.isclass(obj) or inspect.isfunction(obj))
            and getattr(obj, "__module__", None) == module_name
        ]
        candidates += _assigned_names(module)
    else:
        candidates = list(exported)
    for name in dict.fromkeys(candidates):
        if name.startswith("_"):
            continue
        obj = getattr(module, name)
        home = _home_of(module, name, obj)
        if not _is_own_code(obj):
            yield f"{home}.{name}", home, obj
        elif inspect.isclass(obj):
            yield f"{home}.{obj.__qualname__}", home, obj
            for attr, member in vars(obj).items():
                if attr.startswith("_") or not (
                    inspect.isfunction(member)
                    or isinstance(member, (property, classmethod, staticmethod))
                ):
                    continue
                yield f"{home}.{obj.__qualname__}.{attr}", home, member
        else:
            yield f"{home}.{obj.__qualname__}", home, obj


def _is_own_code(obj: Any) -> bool:
    """Whether ``obj`` is a class or function defined in ns_pz (not an alias of a typing form)."""
    return (inspect.isclass(obj) or inspect.isfunction(obj)) and str(
        getattr(obj, "__module__", "")
    ).startswith("ns_pz")


def _home_of(module: types.ModuleType, name: str, obj: Any) -> str:
    """The module that defines ``name``.

    A class's or function's own module; for data, the module it was imported
    from (``from ns_pz.process import NATURE``), followed to its origin.
    """
    if _is_own_code(obj):
        return str(obj.__module__)
    try:
        tree = ast.parse(inspect.getsource(module))
    except (OSError, TypeError):
        return module.__name__
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                if (alias.asname or alias.name) == name and node.module.startswith("ns_pz"):
                    source = importlib.import_module(node.module)
                    return _home_of(source, alias.name, obj)
    return module.__name__


def _has_docstring(obj: Any, qualified: str, home: str) -> bool:
    """Whether ``obj`` has a docstring of its own (or, for an override, an inherited one)."""
    if inspect.isclass(obj) and _is_own_code(obj):
        doc = obj.__doc__ or ""
        # A dataclass without a docstring gets its signature as __doc__.
        return bool(doc.strip()) and not doc.startswith(f"{obj.__name__}(")
    if isinstance(obj, (classmethod, staticmethod)):
        obj = obj.__func__
    if isinstance(obj, property):
        obj = obj.fget
    if inspect.isfunction(obj) and _is_own_code(obj):
        if obj.__doc__ and obj.__doc__.strip():
            return True
        owner_name, _, attr = qualified.rpartition(".")
        owner = _resolve(owner_name)
        return inspect.isclass(owner) and bool(inspect.getdoc(getattr(owner, attr, None)))
    # Data: a docstring right after the assignment (what autodoc reads).
    from sphinx.pycode import ModuleAnalyzer

    attr_docs = ModuleAnalyzer.for_module(home).find_attr_docs()
    return ("", qualified.rpartition(".")[2]) in attr_docs


def _resolve(dotted: str) -> Any:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            obj = getattr(obj, part, None)
        return obj
    return None


# --- API pages -------------------------------------------------------------------------------


def write_api_pages(out: Path) -> None:
    """One page per public module, and an index with one section per layer."""
    out.mkdir(parents=True, exist_ok=True)
    grouped: dict[int, list[str]] = {index: [] for index in range(len(LAYERS))}
    for module in public_modules():
        index = layer_of(module)
        if index is None:
            logger.warning(
                "ns_pz_docs: module %s is in no layer of docs/_ext/ns_pz_docs.py LAYERS; "
                "add it to the layer it belongs to",
                module,
            )
            continue
        grouped[index].append(module)
        _write(out / f"{module}.rst", _module_page(module))
    lines = [
        "API reference",
        "=============",
        "",
        "Every public module, grouped by the layers of the design; imports point down this list",
        "(θ at the bottom of everything, experiments and compat at the top). A package that",
        "re-exports names lists them with links to where each is documented.",
        "",
    ]
    for index, (title, blurb, _) in enumerate(LAYERS):
        lines += [title, "-" * len(title), "", blurb, "", ".. toctree::", "   :maxdepth: 1", ""]
        lines += [f"   {module}" for module in grouped[index]]
        lines.append("")
    _write(out / "index.rst", "\n".join(lines))


def _module_page(module_name: str) -> str:
    module = importlib.import_module(module_name)
    title = f"``{module_name}``"
    lines = [title, "=" * len(title), ""]
    exported = getattr(module, "__all__", None)
    reexported = []
    if exported is not None:
        for name in exported:
            obj = getattr(module, name)
            home = _home_of(module, name, obj)
            if home != module_name:
                target = f"{home}.{obj.__qualname__}" if _is_own_code(obj) else f"{home}.{name}"
                reexported.append((name, target, obj))
    excluded = ", ".join(name for name, _, _ in reexported)
    lines += [f".. automodule:: {module_name}", "   :members:", "   :show-inheritance:"]
    if excluded:
        lines.append(f"   :exclude-members: {excluded}")
    lines.append("")
    if reexported:
        lines += [
            "Re-exported names",
            "-----------------",
            "",
            ".. list-table::",
            "   :widths: 30 70",
            "",
        ]
        for name, target, obj in reexported:
            role = "class" if inspect.isclass(obj) else "func" if _is_own_code(obj) else "data"
            summary = (inspect.getdoc(obj) or "").strip().split("\n")[0] if role != "data" else ""
            lines += [f"   * - :{role}:`{name} <{target}>`", f"     - {summary}"]
        lines.append("")
    if hasattr(module, "__path__"):  # a package: what is inside it, so its page is never empty
        lines += _package_contents(module_name)
    return "\n".join(lines)


def _package_contents(package: str) -> list[str]:
    """A package page's list of its public submodules (and, for ``ns_pz.envs``, the families)."""
    lines: list[str] = []
    if package == "ns_pz.envs":
        import ns_pz

        families: dict[type, list[str]] = {}
        for env_id in ns_pz.registered_envs():
            families.setdefault(ns_pz.spec(env_id).family, []).append(env_id)
        lines += [
            "Families",
            "--------",
            "",
            "Registered here (:func:`ns_pz.envs.registry.registered_envs`; one page each under",
            ":doc:`/families/index`); make them with :func:`ns_pz.envs.registry.make` (the game),",
            ":func:`ns_pz.envs.registry.make_gym` or ``gymnasium.make`` (the view) and",
            ":func:`ns_pz.envs.registry.make_vec` (a batch); :func:`ns_pz.envs.registry.spec`",
            "describes an id and :func:`ns_pz.envs.registry.register` adds one.",
            "",
            ".. list-table::",
            "   :header-rows: 1",
            "   :widths: 30 70",
            "",
            "   * - family",
            "     - registered ids",
        ]
        for family_cls, ids in sorted(families.items(), key=lambda item: item[0].__name__):
            slug = family_cls.__name__.removesuffix("Family")
            ref = f"{family_cls.__module__}.{family_cls.__qualname__}"
            lines += [
                f"   * - :class:`{slug} <{ref}>` (:doc:`page </families/{slug}>`)",
                f"     - {', '.join(f'``{i}``' for i in ids)}",
            ]
        lines.append("")
    inside = [
        name
        for name in public_modules()
        if name.startswith(package + ".") and "." not in name[len(package) + 1 :]
    ]
    if inside:
        lines += ["Modules", "-------", "", ".. list-table::", "   :widths: 35 65", ""]
        for name in inside:
            doc = (importlib.import_module(name).__doc__ or "").strip().split("\n")[0]
            lines += [f"   * - :mod:`{name}`", f"     - {doc}"]
        lines.append("")
    return lines


# --- family pages ----------------------------------------------------------------------------


def write_family_pages(out: Path) -> None:
    """One page per environment family, with everything read from the registry and θ's specs."""
    import ns_pz

    out.mkdir(parents=True, exist_ok=True)
    by_family: dict[type, list[str]] = {}
    for env_id in ns_pz.registered_envs():
        by_family.setdefault(ns_pz.spec(env_id).family, []).append(env_id)
    pages = []
    for family_cls, ids in sorted(by_family.items(), key=lambda item: item[0].__name__):
        slug = family_cls.__name__.removesuffix("Family")
        pages.append(slug)
        _write(out / f"{slug}.rst", _family_page(family_cls, ids))
    lines = [
        "Environment families",
        "====================",
        "",
        "One page per family, generated from the registry and the parameter specs when the docs",
        "build: registering a family adds its page. ``ns-pz envs`` prints the same facts.",
        "",
        ".. list-table::",
        "   :header-rows: 1",
        "   :widths: 25 45 30",
        "",
        "   * - family",
        "     - registered ids",
        "     - θ",
    ]
    for family_cls, ids in sorted(by_family.items(), key=lambda item: item[0].__name__):
        slug = family_cls.__name__.removesuffix("Family")
        theta = ", ".join(s.name for s in family_cls.params_cls.specs())
        lines += [
            f"   * - :doc:`{slug}`",
            f"     - {', '.join(f'``{i}``' for i in ids)}",
            f"     - {theta}",
        ]
    lines += ["", ".. toctree::", "   :hidden:", ""] + [f"   {p}" for p in pages]
    _write(out / "index.rst", "\n".join(lines) + "\n")


def _family_page(family_cls: type, ids: list[str]) -> str:
    import ns_pz

    params_cls = family_cls.params_cls
    slug = family_cls.__name__.removesuffix("Family")
    cls_ref = f"{family_cls.__module__}.{family_cls.__qualname__}"
    params_ref = f"{params_cls.__module__}.{params_cls.__qualname__}"
    summary = (inspect.getdoc(family_cls) or "").split("\n\n")[0]
    lines = [
        f".. currentmodule:: {family_cls.__module__}",
        "",
        slug,
        "=" * len(slug),
        "",
        summary,
        "",
        f"Family :class:`{cls_ref}`; θ is :class:`{params_ref}`.",
        "",
    ]

    lines += [
        "θ",
        "-",
        "",
        ".. list-table::",
        "   :header-rows: 1",
        "   :widths: 16 10 10 22 20 22",
        "",
        "   * - parameter",
        "     - kind",
        "     - unit",
        "     - allowed",
        "     - default",
        "     - meaning",
    ]
    for s in params_cls.specs():
        allowed = s.allowed() if s.kind == "scalar" else "simplex over " + ", ".join(s.outcomes)
        lines += [
            f"   * - ``{s.name}``",
            f"     - {s.kind}",
            f"     - {s.unit or '—'}",
            f"     - ``{allowed}``" if s.kind == "scalar" else f"     - {allowed}",
            f"     - ``{s.default!r}``",
            f"     - {s.doc or '—'}",
        ]
    lines.append("")
    derived = [
        (n, m)
        for n, m in vars(params_cls).items()
        if isinstance(m, property) and not n.startswith("_")
    ]
    if derived:
        lines += ["Derived from θ (computed, never stored):", ""]
        for name, prop in derived:
            first = (inspect.getdoc(prop) or "").split("\n")[0]
            lines.append(f"* ``{name}``: {first}" if first else f"* ``{name}``")
        lines.append("")

    lines += [
        "Registered ids",
        "--------------",
        "",
        ".. list-table::",
        "   :header-rows: 1",
        "   :widths: 25 10 20 20 25",
        "",
        "   * - id",
        "     - time limit",
        "     - state space",
        "     - action space",
        "     - description",
    ]
    rng = np.random.default_rng(0)
    models = []
    for env_id in ids:
        env_spec = ns_pz.spec(env_id)
        family = env_spec.build_family({}, set())
        theta = family.default_params()
        model = family.planning_model(theta, family.initial_state(rng), rng)
        models.append(type(model))
        fixed = "".join(f"; ``{k}={v!r}``" for k, v in env_spec.family_kwargs.items())
        lines += [
            f"   * - ``{env_id}``",
            f"     - {env_spec.max_episode_steps}",
            f"     - ``{family.observation_space}``",
            f"     - ``{family.action_space}``",
            f"     - {env_spec.description}{fixed}",
        ]
    lines.append("")

    options = [
        p
        for p in inspect.signature(family_cls).parameters.values()
        if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    lines += ["Options", "-------", ""]
    if options:
        lines += [
            "Keyword arguments of ``gymnasium.make``, :func:`ns_pz.make` and",
            ":func:`ns_pz.make_gym` that go to the family's constructor:",
            "",
        ]
        lines += [
            f"* ``{p.name}={p.default!r}``" if p.default is not p.empty else f"* ``{p.name}``"
            for p in options
        ]
    else:
        lines.append("The family takes no constructor arguments.")
    lines += [
        "",
        "Every id also takes the NS-MDP arguments ``params``, ``nature``, ``monitor``, "
        "``notification``, ``constraints``, ``max_episode_steps`` and ``render_mode`` "
        f"(render modes here: {', '.join(f'``{m}``' for m in family_cls.render_modes)}).",
        "",
    ]

    lines += [
        "Observation and planning model",
        "------------------------------",
        "",
        "The Gymnasium view observes ``Dict(state, env_change, delta_change, relative_time)``"
        f" with one flag and one change size per parameter "
        f"({len(params_cls.specs())} here, in the order of the θ table); see :doc:`/model`.",
        "",
    ]
    for model_cls in dict.fromkeys(models):
        ref = f"{model_cls.__module__}.{model_cls.__qualname__}"
        first = (inspect.getdoc(model_cls) or "").split("\n\n")[0].replace("\n", " ")
        lines += [f"Planning model: :class:`{ref}`. {first}", ""]
    return "\n".join(lines)


# --- Sphinx hooks ----------------------------------------------------------------------------


def _write(path: Path, text: str) -> None:
    """Write only when the text changed, so Sphinx rebuilds only what changed."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _generate(app: Sphinx) -> None:
    source = Path(app.srcdir)
    with mock(app.config.autodoc_mock_imports):  # as autodoc will import them
        write_family_pages(source / "families")
        write_api_pages(source / "api")


def _check_public_names(app: Sphinx, env: BuildEnvironment) -> None:
    """Warn for each public name without a docstring or without an entry in the docs."""
    with mock(app.config.autodoc_mock_imports):
        _check_names(env)


def _check_names(env: BuildEnvironment) -> None:
    documented = set(env.get_domain("py").objects)  # type: ignore[attr-defined]
    strict = env.config.ns_pz_docs_strict_constants
    loose: list[str] = []
    seen: set[str] = set()
    for module in public_modules():
        if layer_of(module) is None:
            continue
        if f"{module}" not in documented:
            logger.warning("ns_pz_docs: module %s has no entry in the API reference", module)
        exported = set(getattr(importlib.import_module(module), "__all__", ()))
        for qualified, home, obj in public_names(module):
            if qualified in seen:
                continue
            seen.add(qualified)
            constant = not _is_own_code(obj) and qualified.rpartition(".")[2] not in exported
            if (
                constant
                and home == module
                and not strict
                and not _has_docstring(obj, qualified, home)
            ):
                loose.append(qualified)
            elif not _has_docstring(obj, qualified, home):
                logger.warning("ns_pz_docs: public name %s has no docstring", qualified)
            elif qualified not in documented:
                logger.warning("ns_pz_docs: public name %s has no entry in the docs", qualified)
    if loose:
        logger.info(
            "ns_pz_docs: %d module constants outside __all__ have no docstring (set "
            "ns_pz_docs_strict_constants = True to require one): %s",
            len(loose),
            ", ".join(loose),
        )


def setup(app: Sphinx) -> dict[str, Any]:
    """Register the generators and the public-name check."""
    app.add_config_value("ns_pz_docs_strict_constants", False, "env", bool)
    app.connect("builder-inited", _generate)
    app.connect("env-check-consistency", _check_public_names)
    return {"version": "1", "parallel_read_safe": True}
