"""Checkpoints of an AQS run: where the configurations go, how the run is saved
(:func:`save_checkpoint`), the configuration a resumed run starts from
(:func:`resume_configuration`) and every configuration a run saved
(:func:`saved_configurations`)."""

from __future__ import annotations

import math
from pathlib import Path

from jamlab.spheres.potential import Packing
from jamlab.spheres.trace import Trace, read_trace_configuration, write_trace


def checkpoint_paths(out: str | Path) -> tuple[Path, Path]:
    """``(last, snapshots)``: where :func:`~jamlab.spheres.aqs.shear` saves the last configuration
    (``<stem>.last.h5``) and every ``save_every``-th one (``<stem>.configs/step_XXXXXXXX.h5``)."""
    out = Path(out)
    stem = out.name[: -len(out.suffix)] if out.suffix else out.name
    return out.with_name(f"{stem}.last.h5"), out.with_name(f"{stem}.configs")


def save_checkpoint(out: str | Path, trace: Trace, packing: Packing, step: int,
                    snapshot: bool) -> None:
    """Write ``trace`` (the run so far) together with its last configuration ``packing`` (one
    atomic rename: the checkpoint pair), then ``<stem>.last.h5`` (a convenience copy) and, if
    ``snapshot``, the step snapshot (:func:`checkpoint_paths`). Both protocols save this way."""
    from jamlab.spheres.io import write_packing

    last, snapshots = checkpoint_paths(out)
    if snapshot:
        snapshots.mkdir(exist_ok=True)
        write_packing(snapshots / f"step_{step:08d}.h5", packing, aqs_step=int(step))
    # the trace carries its last configuration: one atomic rename writes the checkpoint pair, so
    # a SIGKILL at any moment leaves a resumable trace (resume_configuration); <stem>.last.h5 is
    # written after it for the user (a convenience copy, never needed to resume)
    write_trace(out, trace, configuration=packing)
    write_packing(last, packing, aqs_step=int(step))


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


def saved_configurations(out: str | Path, trace: Trace) -> dict[int, Path]:
    """``{step: file}`` of every configuration the run of ``trace`` (written to ``out``) saved
    beside it (``<stem>.configs/step_*.h5`` and ``<stem>.last.h5``), in step order.
    ``ValueError`` (naming the file) for an unreadable one or one without ``aqs_step``, when
    there is none, and when one that a run with ``save_every`` saves (every multiple of it and
    its last step) is missing: a movie of the run would silently lack a frame."""
    import h5py

    out = Path(out)
    last, snapshots = checkpoint_paths(out)

    def step_of(path: Path) -> int:
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

    files = {}
    if snapshots.is_dir():
        for snap in sorted(snapshots.glob("step_*.h5")):
            files[step_of(snap)] = snap
    if last.is_file():
        files.setdefault(step_of(last), last)
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
