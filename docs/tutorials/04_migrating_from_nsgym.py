"""Migrating from NS-Gym
=====================

``ns_pz.compat`` is NS-Gym's API running on the ns_pz core: replace ``ns_gym`` with
``ns_pz.compat`` in the imports and NS-Gym code runs, with NS-Gym's names, arguments and
``sched(t)`` / ``fn(param, t)`` conventions. The differences (random schedules follow
``reset(seed=...)``, invalid vectors refused, environment settings honoured or refused by name)
are listed in the :mod:`ns_pz.compat` docstring.
"""

# %%
# The repository's migration example, ``examples/nsgym_migration.py``, runs an NS-Gym
# experiment through ``ns_pz.compat`` (FrozenLake whose intended-move probability drops by 0.1
# every second step, with change and delta notification), writes the same experiment natively,
# checks that both produce the same parameter trajectory, and shows what compat refuses that
# NS-Gym accepted:
#
# .. literalinclude:: ../../examples/nsgym_migration.py
#    :language: python
#    :lines: 8-
#
# Natively, a schedule is a nature, every scheduler names its first step, parameters have
# ns_pz's names (``slip`` for NS-Gym's ``P``), and the θ each transition ran under is in
# ``info["theta"]`` when asked for. Running the example prints:

import runpy
from pathlib import Path

import matplotlib.pyplot as plt

# The repository's examples/ folder, found from this file or from wherever the tutorial runs
# (the docs build runs it in docs/tutorials/).
here = Path(globals().get("__file__", Path.cwd())).resolve()
example = next(
    (
        folder / "examples" / "nsgym_migration.py"
        for folder in (*here.parents, Path.cwd(), *Path.cwd().parents)
        if (folder / "examples" / "nsgym_migration.py").is_file()
    ),
    None,
)
if example is None:
    raise FileNotFoundError(
        "this tutorial runs examples/nsgym_migration.py from a checkout of the ns_pz "
        "repository; run it from inside the checkout"
    )
run = runpy.run_path(str(example), run_name="__main__")

# %%
# The two trajectories of the intended-move probability, one per transition:

compat_slips, native_slips = run["compat_slips"], run["native_slips"]
fig, ax = plt.subplots(figsize=(5, 3))
ax.plot([s[0] for s in compat_slips], "o-", label="ns_pz.compat")
ax.plot([s[0] for s in native_slips], "x--", label="native", markersize=10)
ax.set_xlabel("transition")
ax.set_ylabel("P(intended move)")
ax.legend()
fig.tight_layout()
