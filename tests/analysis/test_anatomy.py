"""jamlab.analysis.anatomy against exact cases worked by hand and, for the Lees–Edwards image it
uses (jamlab.lees_edwards), an explicit search over periodic images."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from jamlab.analysis.anatomy import (
    buckler_mask,
    contact_changes,
    event_anatomy,
    event_extent,
    event_field,
    is_localized,
    isotropised_radii,
    moved_particles,
    nonaffine_displacements,
    only_bucklers_rattlers,
    orientation_tensor,
    participation_ratio,
    principal_axes,
)
from jamlab.lees_edwards import minimum_image, wrap


def explicit_image(dr, L, gamma):
    """Shortest dr − t over the lattice t = n_x L e_x + n_y (γL e_x + L e_y) + n_z L e_z."""
    best = None
    k = int(np.ceil(abs(gamma))) + 3
    for nx, ny, nz in itertools.product(range(-k, k + 1), range(-3, 4), range(-3, 4)):
        t = np.array([nx * L + ny * gamma * L, ny * L, nz * L])
        c = dr - t
        if best is None or c @ c < best @ best:
            best = c
    return best


def test_minimum_image_is_the_shortest_lattice_image():
    rng = np.random.default_rng(0)
    L = 5.0
    for gamma in (0.0, 0.13, -0.4, 2.37):
        for _ in range(20):
            # separations short enough (< L/2 after reduction) for the image to be unique
            short = rng.uniform(-1.0, 1.0, 3)
            n = rng.integers(-3, 4, 3)
            dr = short + np.array([n[0] * L + n[1] * gamma * L, n[1] * L, n[2] * L])
            got = minimum_image(dr, L, gamma)
            np.testing.assert_allclose(got, explicit_image(dr, L, gamma), atol=1e-12)
            np.testing.assert_allclose(got, short, atol=1e-12)


def test_affine_shear_has_no_nonaffine_displacement_across_the_boundary():
    rng = np.random.default_rng(1)
    L, g0, g1 = 4.0, 0.05, 0.0512
    xb = rng.uniform(0, L, (30, 3))
    xa = xb.copy()
    xa[:, 0] += (g1 - g0) * xb[:, 1]
    # re-wrap some particles through the y boundary (x shifts by γ1 L) and through x and z
    xa[:5, 1] += L
    xa[:5, 0] += g1 * L
    xa[5:10, 0] -= L
    xa[10:15, 2] += 2 * L
    np.testing.assert_allclose(nonaffine_displacements(xb, xa, L, g0, g1), 0.0, atol=1e-12)
    u = np.zeros((30, 3))
    u[3] = [0.1, -0.2, 0.05]
    np.testing.assert_allclose(nonaffine_displacements(xb, xa + u, L, g0, g1), u, atol=1e-12)


def test_participation_ratio_exact_limits():
    n = 50
    one = np.zeros((n, 3))
    one[7] = [0.0, 0.3, 0.0]
    assert participation_ratio(one) == pytest.approx(1.0 / n)
    assert participation_ratio(np.tile([0.1, 0.0, -0.2], (n, 1))) == pytest.approx(1.0)
    half = np.zeros((n, 2))
    half[: n // 2] = [1.0, 0.0]
    assert participation_ratio(half) == pytest.approx(0.5)
    assert np.isnan(participation_ratio(np.zeros((n, 3))))
    assert is_localized(1.0 / n, n) and not is_localized(0.5, n)


def test_contact_changes_and_bucklers_by_hand():
    before = (np.array([0, 2, 1, 4]), np.array([1, 1, 3, 3]))  # pairs 0-1, 1-2, 1-3, 3-4
    after = (np.array([1, 3, 0]), np.array([0, 4, 4]))  # pairs 0-1, 3-4, 0-4
    opened, closed = contact_changes(before, after, 5)
    np.testing.assert_array_equal(opened, [[1, 2], [1, 3]])
    np.testing.assert_array_equal(closed, [[0, 4]])
    # 2D: bucklers have exactly 3 backbone contacts
    ci = np.array([0, 0, 0, 1, 1, 2, 3, 3, 0, 6])
    cj = np.array([1, 2, 3, 2, 3, 3, 4, 5, 6, 1])
    keep = np.array([True, True, True, True, False, False, True])
    # backbone contacts: 0 → 1,2,3,6 (4); 1 → 0,2,3,6 (4); 2 → 0,1,3 (3); 3 → 0,1,2 (3, its
    # contacts with the rattlers 4, 5 do not count); 6 → 0,1 (2)
    expected = [False, False, True, True, False, False, False]
    np.testing.assert_array_equal(buckler_mask(ci, cj, keep, 2), expected)


def test_only_bucklers_rattlers_rule():
    keep_b = np.array([True, True, True, True, False])
    keep_a = np.array([True, True, True, False, False])
    buck = np.array([False, True, False, False, False])
    assert only_bucklers_rattlers([[1, 2]], [[0, 1]], keep_b, keep_b, buck)  # buckler 1 flips
    assert only_bucklers_rattlers([[0, 3]], np.zeros((0, 2)), keep_b, keep_a, None)  # 3 rattles
    assert not only_bucklers_rattlers([[0, 2]], [[1, 2]], keep_b, keep_b, buck)
    assert not only_bucklers_rattlers(np.zeros((0, 2)), np.zeros((0, 2)), keep_b, keep_b, buck)


def test_event_anatomy_and_moved_particles():
    L = 3.0
    xb = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [0.5, 1.5, 0.5], [2.5, 2.5, 2.5]])
    xa = xb.copy()
    xa[1] += [0.0, 0.0, 0.4]
    pairs = (np.array([0, 0]), np.array([1, 2]))
    keep = np.ones(4, bool)
    an = event_anatomy(xb, xa, L, 0.0, 0.0, pairs, (np.array([0]), np.array([2])), keep, keep)
    assert an.max_displacement == pytest.approx(0.4)
    assert an.participation == pytest.approx(0.25) and an.n_eff == pytest.approx(1.0)
    assert an.localized
    np.testing.assert_array_equal(an.opened, [[0, 1]])
    assert an.closed.shape == (0, 2)
    idx, vec = moved_particles(an.u, 0.1)
    np.testing.assert_array_equal(idx, [1])
    np.testing.assert_allclose(vec, [[0.0, 0.0, 0.4]], atol=1e-15)


def test_event_field_takes_out_the_elastic_part_and_the_translation():
    rng = np.random.default_rng(7)
    n = 6
    keep = np.array([True, True, True, True, False, True])
    event = np.zeros((n, 3))
    event[2] = [0.3, -0.1, 0.2]
    event[keep] -= event[keep].mean(axis=0)  # an event of zero backbone mean
    elastic = rng.normal(size=(n, 3)) * 1e-2
    elastic[~keep] = 0.0
    t = np.array([1e-3, -2e-3, 5e-4])
    u = event + elastic + t
    ev, fraction = event_field(u, elastic, keep)
    np.testing.assert_allclose(ev, event, atol=1e-15)
    assert fraction == pytest.approx(((elastic + t) ** 2).sum() / (u**2).sum(), rel=1e-12)
    # no linear response (NaN): nothing subtracted, and the fraction says so
    ev, fraction = event_field(u, np.full((n, 3), np.nan), keep)
    np.testing.assert_array_equal(ev, u)
    assert np.isnan(fraction)
    # through event_anatomy: the numbers are those of the event field, the raw one is kept
    xb = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [0.5, 1.5, 0.5], [2.5, 2.5, 2.5]])
    xa = xb + [[0.01, 0, 0], [0.01, 0, 0], [0.01, 0, 0.4], [0.01, 0, 0]]
    el = np.zeros((4, 3))
    el[2] = [0.0, 0.0, 0.1]
    pairs = (np.array([0]), np.array([1]))
    k4 = np.ones(4, bool)
    an = event_anatomy(xb, xa, 3.0, 0.0, 0.0, pairs, pairs, k4, k4, elastic=el)
    expect = np.zeros((4, 3))
    expect[2, 2] = 0.3
    expect -= expect.mean(axis=0)  # the translation 0.01 e_x and the mean of the event go
    np.testing.assert_allclose(an.u, expect, atol=1e-15)
    np.testing.assert_allclose(an.raw, xa - xb, atol=1e-15)
    s2 = (expect**2).sum(axis=1)
    assert an.participation == pytest.approx(s2.sum() ** 2 / (4 * (s2**2).sum()))
    raw = xa - xb
    assert an.elastic_fraction == pytest.approx(((raw - expect) ** 2).sum() / (raw**2).sum())


def test_avalanche_figure_draws_the_scaled_field(tmp_path):
    from matplotlib.quiver import Quiver

    from jamlab.plots.anatomy import avalanche_figure

    rng = np.random.default_rng(2)
    pos = rng.uniform(0, 4.0, (20, 3))
    u = rng.normal(size=(20, 3)) * 1e-2
    fig = avalanche_figure(pos, u, 4.0, tmp_path / "a.png", axes=(0, 2), label="event field")
    # the colour bar says what is drawn, the title which projection
    assert fig.axes[1].get_ylabel() == "event field"
    assert "projection on the x–z plane" in fig.axes[0].get_title()
    (q,) = [c for c in fig.axes[0].get_children() if isinstance(c, Quiver)]
    scale = 0.5 / np.sqrt((u**2).sum(axis=1)).max()
    # arrows drawn in increasing |u| order; the set of (U, V) is the projected, scaled field
    got = sorted(zip(q.U, q.V, strict=True))
    np.testing.assert_allclose(got, sorted(zip(scale * u[:, 0], scale * u[:, 2], strict=True)))
    assert (tmp_path / "a.png").stat().st_size > 0


def pairwise_radii(u, x, L, gamma):
    """The radii from ``G = ½ Σ_ij w_i w_j d_ij d_ijᵀ`` (``w = |u|⁴`` normalised; pairs with
    ``w > 1e-13``), ``d_ij`` the shortest of ``x_i − x_j − t`` over the lattice vectors ``t`` of
    :func:`explicit_image`: no centre needed; equal to the centred second moment when the weight
    lies within ``L/4`` of one point."""
    s2 = (u**2).sum(axis=1)
    w = s2**2 / (s2**2).sum()
    idx = np.flatnonzero(w > 1e-13)
    k = int(np.ceil(abs(gamma))) + 3
    t = np.array([[nx * L + ny * gamma * L, ny * L, nz * L] for nx, ny, nz in
                  itertools.product(range(-k, k + 1), range(-3, 4), range(-3, 4))])
    g = np.zeros((3, 3))
    for i in idx:
        c = (x[i] - x[idx])[:, None, :] - t[None, :, :]
        d = c[np.arange(idx.size), np.argmin((c**2).sum(axis=2), axis=1)]
        g += 0.5 * w[i] * (d * w[idx, None]).T @ d
    return np.sqrt(np.clip(np.linalg.eigvalsh(g)[::-1], 0, None))


@pytest.mark.parametrize("gamma", [0.0, 0.3, -1.45])
def test_event_extent_of_a_blob_across_the_boundary_against_pairwise_images(gamma):
    """An anisotropic Gaussian blob centred near a corner of a Lees–Edwards box (so its weight
    straddles the x, y and z boundaries): the radii equal the pairwise explicit-image ones, the
    thin axis is the blob's narrow direction, and a rigid translation of every position (wrapped
    back into the box by the Lees–Edwards rule) changes nothing."""
    rng = np.random.default_rng(5)
    L, n = 6.0, 4000
    x = rng.uniform(0, L, (n, 3))
    centre = np.array([5.8, 0.1, 5.9])
    d = minimum_image(x - centre, L, gamma)
    widths = np.array([0.6, 0.4, 0.2])  # of |u|; the thin direction z
    u = np.zeros((n, 3))
    u[:, 0] = np.exp(-0.5 * np.sum((d / widths) ** 2, axis=1))
    radii, axis = event_extent(u, x, L, gamma)
    np.testing.assert_allclose(radii, pairwise_radii(u, x, L, gamma), rtol=1e-9)
    assert radii[0] >= radii[1] >= radii[2]
    assert abs(axis[2]) > 0.95 and axis[int(np.argmax(np.abs(axis)))] > 0
    shifted = wrap(x + [2.2, 3.1, -1.7], L, gamma)  # the same configuration, moved
    np.testing.assert_allclose(event_extent(u, shifted, L, gamma)[0], radii, rtol=1e-9)


def test_event_extent_of_a_slab_and_limits():
    """A slab of uniform |u| between y = 9.5 and y = 10.5 across the y boundary of a box of side
    10, on a cubic lattice of spacing 0.1: its radii are the lattice's second moments —
    thickness 11 planes ``0.1·√(Σ k²/11)`` (k = −5 … 5) = 0.1 √10, and across the box the
    100-point periodic spread ``0.1·√((100² − 1)/12)`` = 2.8866… — its thin axis ``e_y``; a zero
    field gives NaN, mismatched shapes raise."""
    L, h = 10.0, 0.1
    grid = (np.arange(100) + 0.5) * h
    x = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), axis=-1).reshape(-1, 3)
    dy = (x[:, 1] - 0.05 + L / 2) % L - L / 2  # distance from the plane y = 0.05 (periodic)
    u = np.zeros_like(x)
    u[np.abs(dy) < 0.5 + 1e-9, 0] = 1e-2
    radii, axis = event_extent(u, x, L, 0.0)
    thin = h * np.sqrt(np.mean(np.arange(-5, 6) ** 2.0))
    wide = h * np.sqrt((100**2 - 1) / 12)
    np.testing.assert_allclose(radii, [wide, wide, thin], rtol=1e-9)
    np.testing.assert_allclose(axis, [0, 1, 0], atol=1e-9)
    r0, a0 = event_extent(np.zeros((4, 3)), np.eye(4, 3), L, 0.0)
    assert np.all(np.isnan(r0)) and np.all(np.isnan(a0))
    with pytest.raises(ValueError, match="same shape"):
        event_extent(np.zeros((4, 3)), np.zeros((5, 3)), L, 0.0)


def test_event_anatomy_carries_the_extent():
    """``event_anatomy``'s radii and thin axis are those of its event field at the positions
    before the step."""
    rng = np.random.default_rng(2)
    L = 4.0
    xb = rng.uniform(0, L, (50, 3))
    xa = xb.copy()
    xa[:5] += rng.normal(0, 0.05, (5, 3))
    pairs = (np.array([0]), np.array([1]))
    keep = np.ones(50, bool)
    an = event_anatomy(xb, xa, L, 0.1, 0.1, pairs, pairs, keep, keep)
    radii, axis = event_extent(an.u, xb, L, 0.1)
    np.testing.assert_array_equal(an.radii, radii)
    np.testing.assert_array_equal(an.thin_axis, axis)


def test_isotropised_radii_keep_the_trace_and_the_rank():
    """Turning each offset to a random direction keeps ``Σ w |r|²`` (the trace of ``G``) in
    every draw, so ``Σ r_a²`` equals :func:`event_extent`'s; two equal dominant particles give a
    rank-2 tensor (``r3 = 0``) whatever the draw; a many-particle isotropic field, averaged over
    draws, has equal eigenvalues (2 %); ``u = 0`` gives NaN."""
    rng = np.random.default_rng(3)
    L, n = 8.0, 20000
    x = rng.uniform(0, L, (n, 3))
    d = minimum_image(x - [7.5, 0.2, 4.0], L, 0.4)
    u = np.zeros((n, 3))
    u[:, 1] = np.exp(-0.5 * np.sum((d / [1.2, 0.9, 1.0]) ** 2, axis=1))
    radii = event_extent(u, x, L, 0.4)[0]
    g = []
    for _ in range(200):
        iso = isotropised_radii(u, x, L, 0.4, rng)
        assert np.sum(iso**2) == pytest.approx(np.sum(radii**2), rel=1e-12)
        assert iso[0] >= iso[1] >= iso[2]
        g.append(iso**2)
    mean = np.mean(g, axis=0)
    # the eigenvalues of each draw, averaged: sampling anisotropy only, small for a field spread
    # over ≈ 10³ particles (here the event itself is anisotropic: r3/r1 ≈ 0.75)
    assert mean[2] / mean[0] > 0.85 and radii[2] / radii[0] < 0.8
    two = np.zeros((n, 3))
    two[:2, 0] = 1.0
    for _ in range(5):
        iso = isotropised_radii(two, x, L, 0.0, rng)
        assert iso[2] < 1e-6 * iso[0] and iso[1] > 1e-3 * iso[0]  # λ3 zero to rounding
    assert np.all(np.isnan(isotropised_radii(np.zeros((5, 3)), x[:5], L, 0.0, rng)))


@pytest.mark.parametrize("gamma", [0.0, 0.7])
def test_principal_axes_of_a_rotated_blob(gamma):
    """A Gaussian blob of widths 0.7, 0.45, 0.25 along the columns of a random rotation,
    across the box's corner: the long, middle and thin axes are those columns (to the sampling
    of 20,000 points), the rows are orthonormal with their largest component positive, the radii
    and the thin row equal :func:`event_extent`'s bit for bit."""
    rng = np.random.default_rng(11)
    L, n = 7.0, 20000
    x = rng.uniform(0, L, (n, 3))
    rot, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    d = minimum_image(x - [6.9, 0.2, 6.8], L, gamma) @ rot  # coordinates along the columns
    u = np.zeros((n, 3))
    u[:, 1] = np.exp(-0.125 * np.sum((d / [0.7, 0.45, 0.25]) ** 2, axis=1))  # |u|⁴: widths
    radii, axes = principal_axes(u, x, L, gamma)
    for a in range(3):
        assert abs(axes[a] @ rot[:, a]) > 0.995
        assert axes[a][int(np.argmax(np.abs(axes[a])))] > 0
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(radii, [0.7, 0.45, 0.25], rtol=0.03)
    r, thin = event_extent(u, x, L, gamma)
    np.testing.assert_array_equal(r, radii)
    np.testing.assert_array_equal(thin, axes[-1])
    assert np.all(np.isnan(principal_axes(np.zeros((4, 3)), x[:4], L, gamma)[1]))


def test_orientation_tensor_exact_cases_and_uniform_directions():
    """Exact values: every vector along x gives diag(2/3, −1/3, −1/3); the two diagonals of the
    xy plane give Q_xy = +1/2 and −1/2, their mixture 0; a sign flip or a NaN row changes
    nothing. 200,000 uniform directions give |Q_ab| below 5 standard errors (the variance of
    n_a n_b over the sphere: 4/45 on the diagonal of Q, 1/15 off it)."""
    ex = np.tile([1.0, 0.0, 0.0], (5, 1))
    np.testing.assert_allclose(orientation_tensor(ex), np.diag([2, -1, -1]) / 3, atol=1e-15)
    plus = np.tile([1.0, 1.0, 0.0], (4, 1)) / np.sqrt(2)
    minus = plus * [1.0, -1.0, 1.0]
    assert orientation_tensor(plus)[0, 1] == pytest.approx(0.5, abs=1e-15)
    assert orientation_tensor(-minus)[0, 1] == pytest.approx(-0.5, abs=1e-15)
    both = np.vstack([plus, minus, [[np.nan] * 3]])
    assert orientation_tensor(both)[0, 1] == pytest.approx(0.0, abs=1e-15)
    v = np.random.default_rng(3).standard_normal((200000, 3))
    q = orientation_tensor(v / np.linalg.norm(v, axis=1)[:, None])
    se = np.sqrt(np.where(np.eye(3) > 0, 4 / 45, 1 / 15) / 200000)
    assert np.all(np.abs(q) < 5 * se)
    assert np.trace(q) == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.isnan(orientation_tensor(np.full((2, 3), np.nan))))
    with pytest.raises(ValueError):
        orientation_tensor(np.ones(3))
