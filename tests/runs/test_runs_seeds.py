"""Seeds depend on (master seed, φ, N, index) only."""

import struct

import numpy as np

from jamlab.runs import SampleKey, Study, sample_seed, sample_seed_sequence


def test_seed_is_the_documented_seed_sequence():
    for key, kind, bits in [
        (SampleKey("jamming", 500, 3), 0, 0),
        (SampleKey(0.75, 1000, 299), 1, struct.unpack("<Q", struct.pack("<d", 0.75))[0]),
    ]:
        expected = np.random.SeedSequence(11, spawn_key=(kind, bits, key.n, key.index))
        assert sample_seed_sequence(11, key).generate_state(4).tolist() == (
            expected.generate_state(4).tolist()
        )
        assert sample_seed(11, key) == int(expected.generate_state(1, dtype=np.uint64)[0])


def test_seeds_do_not_depend_on_the_rest_of_the_study():
    small = Study(phi=[0.8], n=[16], samples=4, dgamma=1e-3, gamma_max=1e-2, seed=3)
    big = Study(phi=["jamming", 0.75, 0.8, 0.9], n=[8, 16, 32], samples=10, dgamma=1e-3,
                gamma_max=1e-2, seed=3)  # fmt: skip
    seeds_big = {k: sample_seed(big.seed, k) for k in big.keys()}
    for key in small.keys():
        assert sample_seed(small.seed, key) == seeds_big[key]
    # all distinct, and a different master seed changes them
    assert len(set(seeds_big.values())) == len(seeds_big)
    assert all(sample_seed(4, k) != s for k, s in seeds_big.items())
