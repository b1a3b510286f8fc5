"""The results directory of one run: the spec it belongs to and one file per finished trial.

Layout::

    DIR/spec.json          the resolved spec and its digest (written first)
    DIR/trials/KEY.json    one result row per trial, written atomically
    DIR/results.csv        every row, one per episode, rebuilt from the trial files

Every file is written to a temporary name and renamed, so a run killed at any moment (Ctrl-C,
``kill -9``, a crashed machine) leaves complete trial files and at worst a stray temporary one,
never a half-written result. Resuming skips the trials that have a file with status ``ok`` and
re-runs the rest, errors included. A trial file that cannot be read anyway (a disk that filled
up, a copy cut short, a hand edit) is named and treated as not done: ``--resume`` re-runs its
trial, and reports list it as skipped (:meth:`ResultStore.unreadable`).

Only one run at a time writes into a directory (:mod:`ns_pz.experiments.lock`).
"""

from __future__ import annotations

import csv
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from ns_pz.experiments.spec import ExperimentSpec, SpecError
from ns_pz.experiments.trials import COLUMNS
from ns_pz.files import as_if_created


class ResultStore:
    """Reads and writes the results directory ``root``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.trials_dir = self.root / "trials"

    # -- setup ---------------------------------------------------------------------------
    def check(self, spec: ExperimentSpec, resume: bool) -> None:
        """Refuse a directory that cannot take ``spec``'s results; write nothing.

        Raises:
            SpecError: The directory holds results of another spec, trial files without a
                spec.json, or results of this spec while ``resume`` is off (nothing is ever
                mixed or silently overwritten); or ``root`` is a file.
        """
        if self.root.exists() and not self.root.is_dir():
            raise SpecError(f"--out {self.root} is a file, not a directory")
        meta = self.root / "spec.json"
        if not meta.exists():
            if any(self.trials_dir.glob("*.json")):
                raise SpecError(
                    f"{self.root} holds trial results but no spec.json; use another --out"
                )
            return
        stored = _read_record(meta)
        if stored.get("digest") != spec.digest():
            raise SpecError(
                f"{self.root} holds results of a different spec (digest "
                f"{stored.get('digest')}; this {spec.name!r} at size {spec.size!r} is "
                f"{spec.digest()}: {_difference(stored.get('spec', {}), spec.to_dict())}). "
                "Use another --out directory."
            )
        if not resume and any(self.trials_dir.glob("*.json")):
            raise SpecError(
                f"{self.root} already holds results of this spec; pass --resume to finish "
                "it, or use another --out directory"
            )

    def prepare(self, spec: ExperimentSpec, resume: bool) -> None:
        """:meth:`check`, then make the directory ready for ``spec``."""
        self.check(spec, resume)
        self.trials_dir.mkdir(parents=True, exist_ok=True)
        meta = self.root / "spec.json"
        record = {"name": spec.name, "digest": spec.digest(), "spec": spec.to_dict()}
        _write_atomic(meta, json.dumps(record, indent=2, sort_keys=True))

    def spec_record(self) -> dict[str, Any]:
        """What :meth:`prepare` stored.

        Raises:
            SpecError: ``root`` is not a results directory.
        """
        meta = self.root / "spec.json"
        if not meta.is_file():
            raise SpecError(f"{self.root} is not a results directory (no spec.json)")
        return _read_record(meta)

    # -- trials ----------------------------------------------------------------------------
    def finished(self, digest: str) -> set[str]:
        """Keys of the trials of the spec with ``digest`` that have a result with status ``ok``.

        Raises:
            SpecError: A trial file belongs to another spec.
        """
        done = set()
        for row in self.rows():
            if row["spec_hash"] != digest:
                raise SpecError(
                    f"{self.root}/trials/{row['trial']}.json belongs to spec {row['spec_hash']}, "
                    f"not {digest}; use another --out directory"
                )
            if row["status"] == "ok":
                done.add(row["trial"])
        return done

    def write(self, row: dict[str, Any]) -> None:
        """Store one trial's row (atomically)."""
        _write_atomic(self.trials_dir / f"{row['trial']}.json", json.dumps(row, sort_keys=True))

    def rows(self) -> list[dict[str, Any]]:
        """Every readable stored row, ordered by trial key (see :meth:`unreadable`)."""
        return self._scan()[0]

    def unreadable(self) -> list[tuple[Path, str]]:
        """Trial files that are not a result row (cut short, not JSON), with the reason."""
        return self._scan()[1]

    def _scan(self) -> tuple[list[dict[str, Any]], list[tuple[Path, str]]]:
        rows, bad = [], []
        for path in sorted(self.trials_dir.glob("*.json")):
            try:
                row = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
                bad.append((path, str(error)))
                continue
            missing = [key for key in _KEYS if not isinstance(row, dict) or key not in row]
            if missing:
                bad.append((path, f"not a result row (no {', '.join(missing)})"))
            else:
                rows.append(row)
        return rows, bad

    def write_csv(self) -> Path:
        """Rebuild ``results.csv`` from the trial files; return its path."""
        path = self.root / "results.csv"
        rows = self.rows()
        with tempfile.NamedTemporaryFile(
            "w", dir=self.root, prefix=".results.", suffix=".tmp", delete=False, newline=""
        ) as handle:
            writer = csv.DictWriter(handle, fieldnames=COLUMNS)
            writer.writeheader()
            for row in rows:
                writer.writerow({column: row.get(column) for column in COLUMNS})
            handle.flush()
            os.fsync(handle.fileno())
        as_if_created(handle.name, replacing=path)
        os.replace(handle.name, path)
        return path


def _difference(old: dict[str, Any], new: dict[str, Any]) -> str:
    """The top-level fields that differ between two spec records."""
    fields = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    return f"{', '.join(fields)} differ" if fields else "same fields, another ns_pz version"


_KEYS = ("trial", "status", "spec_hash")
"""Fields every trial file has; :meth:`ResultStore.finished` and the reports rely on them."""


def _read_record(meta: Path) -> dict[str, Any]:
    """``spec.json``, or a :class:`SpecError` naming it."""
    try:
        record = json.loads(meta.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise SpecError(
            f"{meta} is not valid JSON ({error}); use another --out directory"
        ) from None
    if not isinstance(record, dict) or "spec" not in record:
        raise SpecError(f"{meta} is not a spec record (no 'spec'); use another --out directory")
    return record


def _write_atomic(path: Path, text: str) -> None:
    with tempfile.NamedTemporaryFile(
        "w", dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False
    ) as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    as_if_created(handle.name, replacing=path)
    os.replace(handle.name, path)
