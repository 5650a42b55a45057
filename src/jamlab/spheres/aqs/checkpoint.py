"""Checkpoints of an AQS run: where the configurations go and how the run is saved."""

from __future__ import annotations

from pathlib import Path

from jamlab.spheres.potential import Packing
from jamlab.spheres.trace import Trace, write_trace


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
    # a SIGKILL at any moment leaves a resumable trace (jamlab.cli.shear.resume_configuration);
    # <stem>.last.h5 is written after it for the user (a convenience copy, never needed to resume)
    write_trace(out, trace, configuration=packing)
    write_packing(last, packing, aqs_step=int(step))
