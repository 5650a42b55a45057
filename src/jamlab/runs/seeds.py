"""Per-sample seeds derived from the master seed, independent of scheduling.

A sample's seed sequence is ::

    numpy.random.SeedSequence(entropy=master_seed,
                              spawn_key=(PHI_KIND, phi_bits, N, sample_index))

with ``PHI_KIND = 0, phi_bits = 0`` for ``φ = "jamming"`` and ``PHI_KIND = 1``,
``phi_bits`` = the IEEE-754 bit pattern of the float64 ``φ`` (as an unsigned 64-bit integer)
otherwise. The spawn key holds the sample's *values*, never positions in a list or a counter, so

- the seed does not depend on the worker count, the order in which samples run or the machine;
- adding a φ or N value to a study, or more samples, leaves every existing sample's seed unchanged;
- different (φ, N, index) give statistically independent streams (SeedSequence hashing).

The integer handed to the preparation (``jam``/``prepare``, which call
``numpy.random.default_rng(seed)``) is the first 64-bit word of ``generate_state``.
"""

from __future__ import annotations

import struct

import numpy as np

from jamlab.runs.study import SampleKey

__all__ = ["spawn_key", "sample_seed_sequence", "sample_seed"]

_KIND_KEYWORD = {"jamming": 0}
_KIND_NUMBER = 1


def spawn_key(key: SampleKey) -> tuple[int, int, int, int]:
    """``(kind, phi_bits, N, index)`` as documented in the module docstring."""
    if isinstance(key.phi, str):
        if key.phi not in _KIND_KEYWORD:
            raise ValueError(f"no seed rule for phi keyword {key.phi!r}")
        kind, bits = _KIND_KEYWORD[key.phi], 0
    else:
        kind = _KIND_NUMBER
        (bits,) = struct.unpack("<Q", struct.pack("<d", float(key.phi)))
    return (kind, int(bits), int(key.n), int(key.index))


def sample_seed_sequence(master_seed: int, key: SampleKey) -> np.random.SeedSequence:
    """The sample's :class:`numpy.random.SeedSequence` (see the module docstring)."""
    if master_seed < 0:
        raise ValueError(f"master seed must be >= 0, got {master_seed}")
    return np.random.SeedSequence(entropy=int(master_seed), spawn_key=spawn_key(key))


def sample_seed(master_seed: int, key: SampleKey) -> int:
    """A 64-bit integer seed for ``numpy.random.default_rng`` in the sample's preparation."""
    state = sample_seed_sequence(master_seed, key).generate_state(1, dtype=np.uint64)
    return int(state[0])
