"""Predictors of the next elastic step: the weighted least-squares extrapolation of the branch
(:class:`BranchPath`) and the multisecant correction from recent chord steps (:class:`Secants`)."""

from __future__ import annotations

import numpy as np


class BranchPath:
    """The minima of the current smooth piece of the branch, for the predictor of the next step.

    Holds (at most ``depth``) cumulative non-affine displacements ``z_k`` of the minima since the
    piece began (a plastic step or a contact change) and their residual forces ``noise_k``. The
    predicted non-affine displacement of the next step is ``ẑ(+1) − z₀`` with ``ẑ`` the
    polynomial of degree ``≤ degree`` fitted to the ``z_k`` by least squares weighted with
    ``1/max(noise_k, floor)²``, in the step index: the fit averages the residual noise of the
    minima instead of amplifying it as exact interpolation does (``4, −6, 4, −1`` for a cubic
    through four points), and minima recorded with larger residuals count less. After a
    contact change the first prediction is the step that contained it (``straddle``).
    Stored as a ring buffer: one matrix-vector product per prediction.
    """

    def __init__(self, depth: int, degree: int, floor: float) -> None:
        self.depth, self.degree, self.floor = depth, degree, floor
        self.buf: np.ndarray | None = None
        self.noise = np.zeros(depth)
        self.head = -1
        self.count = 0
        self.straddle: np.ndarray | None = None

    def reset(self) -> None:
        self.count, self.straddle = 0, None

    def add(self, u: np.ndarray, noise: float, kinked: bool) -> None:
        flat = u.ravel()
        self.shape = u.shape
        if self.buf is None or self.buf.shape[1] != flat.size:
            self.buf, self.count = np.zeros((self.depth, flat.size)), 0
        if kinked or self.count == 0:
            self.head, self.count = 0, 1
            self.buf[0] = 0.0
            self.noise[0] = noise
            self.straddle = u if kinked else None
            return
        new = (self.head + 1) % self.depth
        np.add(self.buf[self.head], flat, out=self.buf[new])
        self.head = new
        self.noise[new] = noise
        self.count = min(self.count + 1, self.depth)
        self.straddle = None

    def predict(self) -> np.ndarray | None:
        m = self.count
        if m == 0:
            return None
        if m == 1:
            return self.straddle
        degree = min(self.degree, m - 1)
        idx = (self.head - np.arange(m)) % self.depth  # newest first
        t = -np.arange(m, dtype=np.float64) / (m - 1)  # steps scaled to [-1, 0]: conditioning
        v = np.vander(t, degree + 1, increasing=True)
        sw = 1.0 / np.maximum(self.noise[idx], self.floor)
        # coefficients c with ẑ(t₊) = Σ c_k z_k for the weighted fit (Σ c_k = 1), by QR of
        # √W V = Q R: c = √W Q R⁻ᵀ e(t₊), e(t₊) the monomials at the next step t₊ = 1/(m−1)
        q, r = np.linalg.qr(sw[:, None] * v)
        e = (1.0 / (m - 1)) ** np.arange(degree + 1)
        c = sw * (q @ np.linalg.solve(r.T, e))
        full = np.zeros(self.depth)
        full[idx] = c
        full[self.head] -= 1.0  # ẑ(+1) − z₀
        return (full @ self.buf).reshape(self.shape)


class Secants:
    """Recent chord steps ``s_k = P⁻¹ r_k`` and the force changes ``y_k = r_k − r'_k ≈ K s_k``
    they produced (free coordinates, neighbour-list order), for a correction without a solve:
    a residual ``r`` close to their span is removed by ``dx = S a``, ``a = argmin ‖r − Y a‖``
    (a multisecant step); the force at the corrected point decides whether it is kept. Ring
    buffers with the Gram matrix ``YᵀY`` kept up to date."""

    def __init__(self, depth: int) -> None:
        self.depth = depth
        self.s: np.ndarray | None = None
        self.y: np.ndarray | None = None
        self.gram = np.zeros((depth, depth))
        self.head = -1
        self.count = 0

    def clear(self) -> None:
        self.count = 0

    def push(self, s: np.ndarray, y: np.ndarray) -> None:
        s, y = s.ravel(), y.ravel()
        if self.s is None or self.s.shape[1] != s.size:
            self.s, self.y = np.zeros((self.depth, s.size)), np.zeros((self.depth, s.size))
            self.count = 0
        self.head = (self.head + 1) % self.depth
        self.s[self.head] = s
        self.y[self.head] = y
        self.count = min(self.count + 1, self.depth)
        row = self.y @ y  # (rows not filled yet are never read)
        self.gram[self.head, :] = row
        self.gram[:, self.head] = row

    def correction(self, r: np.ndarray) -> np.ndarray | None:
        m = self.count
        if m == 0:
            return None
        idx = (self.head - np.arange(m)) % self.depth
        b = (self.y @ r.ravel())[idx]
        g = self.gram[np.ix_(idx, idx)]
        try:
            a = np.linalg.solve(g + 1e-14 * np.trace(g) * np.eye(m), b)
        except np.linalg.LinAlgError:
            return None
        full = np.zeros(self.depth)
        full[idx] = a
        return (full @ self.s).reshape(r.shape)
