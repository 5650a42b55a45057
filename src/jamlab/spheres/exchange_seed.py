"""Seeds in the exchange formats (:mod:`jamlab.spheres.exchange`), exact over the whole range
``[0, 2^64 − 1]`` of :func:`jamlab.validation.seed` (``docs/formats.md``, "Exchange formats").

- GSD: ``log/jamlab/seed`` is uint64 ``[seed]``, or int64 ``[−1]`` for an unknown seed; files
  written before stored every seed in int64 (``−1`` = unknown), which cannot hold ``≥ 2^63``.
- extended XYZ: ``seed=`` in the comment line, a decimal; ASE reads one above ``2^63 − 1`` as a
  float, so that one is taken from the comment line itself.
"""

from __future__ import annotations

import os
import re

import numpy as np

from jamlab import validation

__all__ = ["gsd_seed_chunk", "seed_of_gsd_chunk", "extxyz_seed", "extxyz_raw_seeds"]


def gsd_seed_chunk(seed: int | None) -> np.ndarray:
    """The ``log/jamlab/seed`` chunk: ``uint64 [seed]`` (every seed in ``[0, 2^64 − 1]``), or
    ``int64 [−1]`` for an unknown seed (as files before stored every seed, in int64)."""
    if seed is None:
        return np.array([-1], np.int64)
    return np.array([validation.seed("seed", seed)], np.uint64)


def seed_of_gsd_chunk(chunk: np.ndarray | None, path: str | os.PathLike) -> int | None:
    """The seed of a ``log/jamlab/seed`` chunk (:func:`gsd_seed_chunk`; int64 ``−1`` or no chunk:
    unknown); ``ValueError`` unless it is one integer naming a valid seed."""
    if chunk is None:
        return None
    chunk = np.asarray(chunk)
    if chunk.shape != (1,) or chunk.dtype.kind not in "iu":
        raise ValueError(f"{path}: log/jamlab/seed must hold one integer, got {chunk!r}")
    value = int(chunk[0])
    if chunk.dtype.kind == "i" and value == -1:
        return None
    return validation.seed(f"log/jamlab/seed in {path}", value)


def extxyz_seed(value: object, path: str | os.PathLike, block: int) -> int | None:
    """The seed of block ``block`` (``−1``: unknown). ASE turns a decimal above ``2^63 − 1`` into
    a float, which may have lost the last digits: then the exact decimal is taken from the
    block's comment line itself."""
    if isinstance(value, float | np.floating):
        try:
            value = extxyz_raw_seeds(path)[block]
        except (ValueError, IndexError, OSError, UnicodeDecodeError):
            value = None
        if not (isinstance(value, str) and re.fullmatch(r"\d+", value)):
            raise ValueError(f"{path}: block {block}: the seed is not an integer")
    seed = validation.integer(f"seed of block {block} in {path}", value, minimum=-1)
    return None if seed == -1 else validation.seed(f"seed of block {block} in {path}", seed)


def extxyz_raw_seeds(path: str | os.PathLike) -> list[str | None]:
    """The text of ``seed=...`` in each block's comment line (``None`` where there is none)."""
    seeds: list[str | None] = []
    with open(path) as fh:
        lines = iter(fh)
        for line in lines:
            if not line.strip():
                continue
            n = int(line)
            match = re.search(r"(?:^|\s)seed=\"?([^\s\"]+)", next(lines, ""))
            seeds.append(match.group(1) if match else None)
            for _ in range(n):
                next(lines, None)
    return seeds
