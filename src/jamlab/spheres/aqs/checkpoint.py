"""Checkpoints of an AQS run: where the configurations go, how the run is saved
(:func:`save_checkpoint`), the configuration a resumed run starts from
(:func:`resume_configuration`) and every configuration a run saved
(:func:`saved_configurations`).

A new run to the ``out`` of an earlier one (``jamlab shear --force``) replaces that run's files
at its own first save, not before (:func:`begin_replacement`): until then the earlier trace,
``<stem>.last.h5`` and every ``<stem>.configs/step_*.h5`` stay where they are. The first save
moves the old snapshots into the hidden sibling folder ``.<name>.replacing`` (which records the
old trace's identity), writes the new snapshot, renames the new trace over ``out`` (the one
atomic commit), writes ``<stem>.last.h5`` and removes the folder. A run killed inside that
window leaves the folder behind, and :func:`recover_replacement` (first thing of every
``jamlab shear`` to that ``out``) finishes it: the old snapshots go back if ``out`` is still the
old trace, else they are deleted."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

from jamlab.spheres.potential import Packing
from jamlab.spheres.trace import Trace, read_trace_configuration, write_trace


def checkpoint_paths(out: str | Path) -> tuple[Path, Path]:
    """``(last, snapshots)``: where :func:`~jamlab.spheres.aqs.shear` saves the last configuration
    (``<stem>.last.h5``) and every ``save_every``-th one (``<stem>.configs/step_XXXXXXXX.h5``)."""
    out = Path(out)
    stem = out.name[: -len(out.suffix)] if out.suffix else out.name
    return out.with_name(f"{stem}.last.h5"), out.with_name(f"{stem}.configs")


def snapshot_files(snapshots: Path) -> list[Path]:
    """The snapshots ``step_*.h5`` in a run's folder ``<stem>.configs`` (:func:`checkpoint_paths`),
    in step order (the names are zero-padded); empty when the folder does not exist."""
    return sorted(snapshots.glob("step_*.h5")) if snapshots.is_dir() else []


def save_checkpoint(out: str | Path, trace: Trace, packing: Packing, step: int,
                    snapshot: bool) -> None:
    """Write ``trace`` (the run so far) together with its last configuration ``packing`` (one
    atomic rename: the checkpoint pair), then ``<stem>.last.h5`` (a convenience copy) and, if
    ``snapshot``, the step snapshot (:func:`checkpoint_paths`). Both protocols save this way."""
    from jamlab.spheres.io import write_packing

    last, snapshots = checkpoint_paths(out)
    aside = replacement_path(out)
    replacing = (aside / _OLD).is_file()  # the first save of a run replacing an earlier one
    if replacing:
        _move_aside(snapshots, aside)
    if snapshot:
        snapshots.mkdir(exist_ok=True)
        write_packing(snapshots / f"step_{step:08d}.h5", packing, aqs_step=int(step))
    # the trace carries its last configuration: one atomic rename writes the checkpoint pair, so
    # a SIGKILL at any moment leaves a resumable trace (resume_configuration); <stem>.last.h5 is
    # written after it for the user (a convenience copy, never needed to resume)
    write_trace(out, trace, configuration=packing)
    write_packing(last, packing, aqs_step=int(step))
    if replacing:
        shutil.rmtree(aside)  # the new run's files now replace the earlier run's


_OLD, _HELD, _MOVED = "old.json", "configs", "moved"
"""In ``.<name>.replacing``: the old trace's identity, the old snapshots, and the flag that all
of them are there (from then on a ``step_*.h5`` in ``<stem>.configs`` is the new run's)."""


def replacement_path(out: str | Path) -> Path:
    """``.<name>.replacing`` beside ``out``: where a run replacing an earlier run's files keeps
    them until its first save (module docstring)."""
    out = Path(out)
    return out.with_name(f".{out.name}.replacing")


def _identity(path: Path) -> list[int] | None:
    # device and inode: the new trace is written under another name while the old one exists and
    # renamed over it, so it never has the old inode; a touch or read does not change them
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return [st.st_dev, st.st_ino]


def begin_replacement(out: str | Path) -> None:
    """Make the next :func:`save_checkpoint` to ``out`` replace the earlier run's files there
    (its trace, ``<stem>.last.h5``, its ``step_*.h5`` snapshots): record which files they are in
    :func:`replacement_path`. Nothing is moved or deleted here; call
    :func:`recover_replacement` first (a leftover of a killed run) and after a failed run."""
    from jamlab.files import atomic_write_text

    out = Path(out)
    last = checkpoint_paths(out)[0]
    aside = replacement_path(out)
    aside.mkdir()
    record = {"trace": _identity(out), "last": _identity(last)}
    atomic_write_text(aside / _OLD, json.dumps(record))


def _move_aside(snapshots: Path, aside: Path) -> None:
    from jamlab.files import fsync_dir

    held = aside / _HELD
    held.mkdir(exist_ok=True)
    if snapshots.is_dir():
        for f in snapshot_files(snapshots):
            os.replace(f, held / f.name)
        if not any(snapshots.iterdir()):
            snapshots.rmdir()
    fsync_dir(held)
    (aside / _MOVED).touch()
    fsync_dir(aside)


def replacement_pending(out: str | Path) -> bool:
    """Whether the earlier run's snapshots at ``out`` are (maybe partly) moved aside by a
    replacing run that has not committed its trace yet, or was killed doing so."""
    return (replacement_path(out) / _HELD).is_dir()


def recover_replacement(out: str | Path) -> str | None:
    """Finish a replacement of the run at ``out`` that did not complete (a run killed or failed
    between :func:`begin_replacement` and the end of its first save): if ``out`` is still the
    earlier trace, its snapshots go back into ``<stem>.configs`` (any ``step_*.h5`` of the new
    run there is deleted: it belongs to no trace); if the new trace replaced it, the earlier
    snapshots are deleted and a ``<stem>.last.h5`` still the earlier run's (or missing) is
    written from the new trace. Returns what was done (``None``: nothing to do). Safe to
    repeat if killed."""
    from jamlab.spheres.io import write_packing
    from jamlab.spheres.trace import read_trace

    out = Path(out)
    aside = replacement_path(out)
    if not aside.is_dir():
        return None
    last, snapshots = checkpoint_paths(out)
    held = aside / _HELD
    try:
        old = json.loads((aside / _OLD).read_text())
    except FileNotFoundError:  # killed inside begin_replacement: nothing was moved
        old = {"trace": _identity(out), "last": None}
    if _identity(out) == old["trace"] or not out.is_file():
        if held.is_dir():
            if (aside / _MOVED).exists():
                for f in snapshot_files(snapshots):
                    f.unlink()  # the new run's, written before its trace replaced out
                (aside / _MOVED).unlink()
            for f in sorted(held.iterdir()):
                snapshots.mkdir(exist_ok=True)
                os.replace(f, snapshots / f.name)
        done = f"the earlier run in {out} is kept whole (an interrupted replacement undone)"
    else:
        if _identity(last) in (None, old["last"]):  # not yet written by the new run
            trace = read_trace(out)
            write_packing(last, resume_configuration(out, trace), aqs_step=trace.n_steps)
        done = f"{out} is the new run's (the earlier run's leftover files removed)"
    shutil.rmtree(aside)
    return done


def resume_configuration(out: str | Path, previous: Trace) -> Packing:
    """The saved configuration at the strain of the trace's last row: the one stored in the
    trace file ``out`` itself (written with it by one rename), else ``<stem>.last.h5`` or, if the
    run was killed between writing that and the trace, the snapshot of the same step.
    ``ValueError`` if there is none."""
    from jamlab.spheres.box import Box
    from jamlab.spheres.io import read_packing

    out = Path(out)
    last, snapshots = checkpoint_paths(out)
    step = previous.n_steps
    strain = float(previous.gamma[-1])
    stored = read_trace_configuration(out)
    if stored is not None and stored["step"] == step:
        seed = int(stored["seed"])
        positions = stored["positions"]
        box = Box(float(stored["box_length"]), positions.shape[1], float(stored["strain"]))
        return Packing(
            positions,
            box,
            seed=None if seed < 0 else seed,
            diameters=stored.get("diameters"),
            alpha=stored.get("alpha", 2.0),
        )
    tried = []
    for candidate in (last, snapshots / f"step_{step:08d}.h5"):
        if not candidate.is_file():
            continue
        packing = read_packing(candidate)
        if math.isclose(packing.strain, strain, rel_tol=0, abs_tol=1e-15):
            return packing
        tried.append(f"{candidate} is at strain {packing.strain!r}")
    raise ValueError(
        f"no saved configuration at the last strain {strain!r} (step {step}) of {out}"
        + (f": {'; '.join(tried)}" if tried else f"; expected {last}")
    )


def _saved_step(path: Path) -> int:
    """The ``aqs_step`` of a configuration an AQS run saved; ``ValueError`` naming the file if it
    is not one (unreadable, or without the attribute)."""
    import h5py

    try:
        with h5py.File(path, "r") as h5:
            step = h5.attrs.get("aqs_step")
    except OSError:
        raise ValueError(
            f"{path}: not a readable HDF5 file (a damaged saved configuration)"
        ) from None
    if step is None:
        raise ValueError(f"{path} has no aqs_step attribute: not a configuration of an AQS run")
    return int(step)


def foreign_snapshots(snapshots: Path) -> list[tuple[Path, str]]:
    """The files in a snapshot folder named like snapshots (:func:`snapshot_files`) that no AQS run
    saved there: ``(file, why)`` for each one that is unreadable, has no ``aqs_step`` or whose
    ``aqs_step`` is not the step in its name. A replacing run (``shear --force``) would move
    and delete them with the earlier run's snapshots, or write its own over them."""
    foreign = []
    for path in snapshot_files(snapshots):
        try:
            step = _saved_step(path)
        except ValueError as exc:
            foreign.append((path, str(exc)))
            continue
        named = path.stem[len("step_"):]
        if not (named.isdigit() and int(named) == step):
            foreign.append((path, f"{path} holds step {step}, not the step in its name"))
    return foreign


def saved_configurations(out: str | Path, trace: Trace) -> dict[int, Path]:
    """``{step: file}`` of every configuration the run of ``trace`` (written to ``out``) saved
    beside it (``<stem>.configs/step_*.h5`` and ``<stem>.last.h5``), in step order.
    ``ValueError`` (naming the file) for an unreadable one or one without ``aqs_step``, when
    there is none, and when one that a run with ``save_every`` saves (every multiple of it and
    its last step) is missing: a movie of the run would silently lack a frame."""
    out = Path(out)
    last, snapshots = checkpoint_paths(out)
    files = {_saved_step(snap): snap for snap in snapshot_files(snapshots)}
    if last.is_file():
        files.setdefault(_saved_step(last), last)
    if not files:
        raise ValueError(
            f"{out}: no saved configuration beside the trace ({last.name} or {snapshots.name}/)"
        )
    every = int(trace.attrs.get("save_every", 0) or 0)
    if every:
        expected = set(range(every, trace.n_steps, every)) | {trace.n_steps}
        missing = sorted(expected - set(files))
        if missing:
            shown = ", ".join(map(str, missing[:5])) + (", ..." if len(missing) > 5 else "")
            raise ValueError(f"{out}: {len(missing)} saved configuration(s) missing from "
                             f"{snapshots.name}/ (steps {shown}; the run saved every {every})")
    return dict(sorted(files.items()))
