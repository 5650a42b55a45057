"""Numba kernels of the exact best-first Derrida–Ruelle cascade sampler.

Plain-Python summary of what :func:`sample_batch` computes (see :mod:`jamlab.theory.cascade` for
the derivation). Work with ``d = |δγ| >= 0`` (a negative strain is handled by the caller by
flipping the sign of all stresses). Each edge from a level-``i`` node to a child carries an energy
increment ``Δu``, a stress increment ``s ~ N(0, v_i)``, ``v_i = q_{i+1} - q_i``, and the key
increment ``a = Δu - d s⁺``. For a leaf, ``A = Σ a <= min(U, U - d Σ)``. In ``a`` the children of a
level-``i`` node are a Poisson process of intensity ``T_i e^{y_i a}``,
``T_i = ½ + e^{y_i² d² v_i / 2} Φ(y_i d √v_i)``; the minimum of ``A`` over a level-``i`` subtree is
Gumbel, ``P(min > m) = exp(-(c_i/y_i) e^{y_i m})``, ``c_k = T_k``,
``c_i = T_i (c_{i+1}/y_{i+1})^{r_i} Γ(1-r_i)``, ``r_i = y_i/y_{i+1}``. Child slots are popped from
a heap in increasing lower bound; a popped slot is materialised (its own ``a`` and the remainder
``G`` of its subtree minimum: ``(c_{i+1}/y_{i+1}) e^{y_{i+1} G} ~ Gamma(1 - r_i, 1)``), its first
child slot (key unchanged) and its parent's next sibling slot (``Λ -> Λ + Exp(1)``,
``Λ(m) = (c_i/y_i) e^{y_i m}``) are pushed. The search stops once the heap top is ``>=`` both the
best ``U`` and the best ``U - dΣ`` found, so no unexplored leaf can change either minimiser.
"""

# numba kernels draw from numba's own per-thread generator, seeded explicitly by the caller
# ruff: noqa: NPY002
from __future__ import annotations

import numpy as np
from numba import njit

# columns of the per-sample output
OUT_DU, OUT_DS, OUT_LEVEL, OUT_NSTATES, OUT_NNODES = 0, 1, 2, 3, 4
N_OUT = 5


@njit(cache=True)
def _grow_f(a: np.ndarray, n: int) -> np.ndarray:
    b = np.empty(max(2 * a.shape[0], n), dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def _grow_i(a: np.ndarray, n: int) -> np.ndarray:
    b = np.empty(max(2 * a.shape[0], n), dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def _log_gamma_variate(shape: float) -> float:
    """log of a Gamma(shape, 1) variate without underflow for small ``shape``.

    For ``shape < 1``: ``W = W' U^{1/shape}`` with ``W' ~ Gamma(shape + 1)``, ``U ~ U(0, 1)``.
    """
    if shape >= 1.0:
        return np.log(np.random.gamma(shape, 1.0))
    u = np.random.random()
    while u <= 0.0:
        u = np.random.random()
    return np.log(np.random.gamma(shape + 1.0, 1.0)) + np.log(u) / shape


@njit(cache=True)
def _stress_increment(d: float, y: float, sd: float, p_neg: float) -> float:
    """Draw ``s`` with density ∝ φ_v(s) e^{y d s⁺} (the stress of an edge given its key ``a``)."""
    if np.random.random() < p_neg:
        return -abs(np.random.standard_normal()) * sd
    mean = y * d * sd * sd
    while True:  # N(mean, v) truncated to s > 0; acceptance >= 1/2
        s = mean + sd * np.random.standard_normal()
        if s > 0.0:
            return s


@njit(cache=True)
def _search(
    y: np.ndarray,
    sd: np.ndarray,
    T: np.ndarray,
    c: np.ndarray,
    d: float,
    n: int,
    seed: int,
    max_nodes: int,
    extra: float,
    truncate: bool,
    max_total: float,
    check_after: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int, float]:
    """The best-first search, run for ``n`` independent samples (the one implementation).

    Returns the ``(n, 5)`` per-sample output (see :func:`sample_batch`) and, of the last sample,
    the tree it materialised: parent, level, U, Σ of every node (views of the work arrays), the
    indices of the old and new ground states, and the bound ``reach`` below which it holds every
    node (keys are popped in increasing order). A sample stops once the heap top is
    ``>= max(U*, V*) + extra`` (``extra = 0``: the exact stopping rule; ``extra > 0`` also draws
    every state whose bound ``A`` lies below the threshold, for pictures); then ``reach`` is that
    threshold. Reaching ``max_nodes`` nodes raises, or with ``truncate`` ends the sample there:
    ``reach`` is then the heap top, below the threshold (the caller tells the cases apart).
    Once the samples so far have drawn ``check_after`` nodes, the run stops after the first
    sample at which their mean, times ``n``, exceeds ``max_total``: the output then has fewer
    than ``n`` rows (the samples drawn).
    """
    np.random.seed(seed)
    k = y.shape[0]
    out = np.empty((n, N_OUT))
    cap = 1024
    # node arrays: parent, level (1 = root, k + 1 = state), absolute U, Σ, A
    par = np.empty(cap, np.int64)
    lev = np.empty(cap, np.int64)
    nu = np.empty(cap)
    ns = np.empty(cap)
    na = np.empty(cap)
    # heap of child slots: key (absolute bound), parent node, m (subtree min relative to parent)
    hcap = 1024
    hkey = np.empty(hcap)
    hpar = np.empty(hcap, np.int64)
    hm = np.empty(hcap)
    shape = np.empty(k)
    for i in range(k - 1):
        shape[i] = 1.0 - y[i] / y[i + 1]
    p_neg = 0.5 / T
    nn = 1
    iu = -1
    iv = -1
    reach = np.inf
    total = 0.0
    for t in range(n):
        nn = 1
        par[0] = -1
        lev[0] = 1
        nu[0] = 0.0
        ns[0] = 0.0
        na[0] = 0.0
        # subtree minimum of the root: (c_1/y_1) e^{y_1 G} ~ Exp(1)
        e = np.random.exponential()
        g = np.log(e * y[0] / c[0]) / y[0]
        hn = 1
        hkey[0] = g
        hpar[0] = 0
        hm[0] = g
        best_u = np.inf
        best_v = np.inf
        stop = np.inf  # max(best_u, best_v) + extra
        iu = -1
        iv = -1
        nstates = 0
        reach = np.inf
        while hn > 0:
            if hkey[0] >= stop:
                reach = stop
                break
            if nn >= max_nodes:
                if truncate:
                    reach = hkey[0]
                    break
                raise RuntimeError("cascade sampler exceeded max_nodes")
            p = hpar[0]
            m = hm[0]
            # pop
            hn -= 1
            if hn > 0:
                lk = hkey[hn]
                lp = hpar[hn]
                lm = hm[hn]
                j = 0
                while True:
                    l = 2 * j + 1
                    if l >= hn:
                        break
                    r = l + 1
                    cidx = l
                    if r < hn and hkey[r] < hkey[l]:
                        cidx = r
                    if hkey[cidx] < lk:
                        hkey[j] = hkey[cidx]
                        hpar[j] = hpar[cidx]
                        hm[j] = hm[cidx]
                        j = cidx
                    else:
                        break
                hkey[j] = lk
                hpar[j] = lp
                hm[j] = lm
            # materialise the child of p whose subtree minimum (relative to p) is m
            L = lev[p]  # parent level, 1..k; parameters index L-1
            li = L - 1
            if L < k:
                lw = _log_gamma_variate(shape[li])
                gchild = (lw + np.log(y[li + 1] / c[li + 1])) / y[li + 1]
                a = m - gchild
            else:
                gchild = 0.0
                a = m
            s = _stress_increment(d, y[li], sd[li], p_neg[li])
            du = a + d * max(s, 0.0)
            if nn >= par.shape[0]:
                par = _grow_i(par, nn + 1)
                lev = _grow_i(lev, nn + 1)
                nu = _grow_f(nu, nn + 1)
                ns = _grow_f(ns, nn + 1)
                na = _grow_f(na, nn + 1)
            ch = nn
            nn += 1
            par[ch] = p
            lev[ch] = L + 1
            nu[ch] = nu[p] + du
            ns[ch] = ns[p] + s
            na[ch] = na[p] + a
            # push up to two slots: the child's first child, the parent's next child
            if hn + 2 > hkey.shape[0]:
                hkey = _grow_f(hkey, hn + 2)
                hpar = _grow_i(hpar, hn + 2)
                hm = _grow_f(hm, hn + 2)
            npush = 0
            if L < k:
                npush = 1
            else:
                nstates += 1
                uu = nu[ch]
                vv = uu - d * ns[ch]
                if uu < best_u:
                    best_u = uu
                    iu = ch
                if vv < best_v:
                    best_v = vv
                    iv = ch
                stop = max(best_u, best_v) + extra
            lam = c[li] / y[li] * np.exp(y[li] * m) + np.random.exponential()
            m_next = np.log(lam * y[li] / c[li]) / y[li]
            for q in range(npush + 1):
                if q == 0 and npush == 1:
                    nk = na[ch] + gchild
                    npar = ch
                    nm = gchild
                else:
                    nk = na[p] + m_next
                    npar = p
                    nm = m_next
                j = hn
                hn += 1
                while j > 0:
                    pj = (j - 1) // 2
                    if hkey[pj] > nk:
                        hkey[j] = hkey[pj]
                        hpar[j] = hpar[pj]
                        hm[j] = hm[pj]
                        j = pj
                    else:
                        break
                hkey[j] = nk
                hpar[j] = npar
                hm[j] = nm
        # deepest common ancestor of the two minimisers (none when truncated before any state)
        a1 = iu
        a2 = iv
        while a1 != a2:
            a1 = par[a1]
            a2 = par[a2]
        if iu >= 0:
            out[t, OUT_DU] = nu[iv] - nu[iu]
            out[t, OUT_DS] = ns[iv] - ns[iu]
            out[t, OUT_LEVEL] = lev[a1]
        else:
            out[t, OUT_DU] = np.nan
            out[t, OUT_DS] = np.nan
            out[t, OUT_LEVEL] = -1
        out[t, OUT_NSTATES] = nstates
        out[t, OUT_NNODES] = nn
        total += nn
        if total >= check_after and total / (t + 1) * n > max_total:
            return out[: t + 1], par[:nn], lev[:nn], nu[:nn], ns[:nn], iu, iv, reach
    return out, par[:nn], lev[:nn], nu[:nn], ns[:nn], iu, iv, reach


#: node limit of :func:`sample_tree` (a picture of more nodes is unreadable anyway)
TREE_MAX_NODES = (1 << 16) - 2


def sample_batch(
    y: np.ndarray,
    sd: np.ndarray,
    T: np.ndarray,
    c: np.ndarray,
    d: float,
    n: int,
    seed: int,
    max_nodes: int,
    max_total: float = np.inf,
    check_after: float = np.inf,
) -> np.ndarray:
    """Draw ``n`` independent samples; returns an ``(n, 5)`` array.

    Columns: ``ΔU``, ``ΔΣ`` (in the ``d >= 0`` frame), deepest-common-ancestor level of old and
    new ground states (``k + 1`` when they coincide; overlap ``q[level-1]``), number of states
    (leaves) materialised, number of nodes materialised. ``max_nodes`` bounds the tree size per
    sample (a safety net; exceeding it raises). ``max_total``, ``check_after``: the running
    projection of the whole run's nodes (:func:`_search`); the array has fewer than ``n`` rows
    when it stopped the run. The samples drawn do not depend on them.
    """
    return _search(y, sd, T, c, d, n, seed, max_nodes, 0.0, False, max_total, check_after)[0]


def sample_tree(
    y: np.ndarray,
    sd: np.ndarray,
    T: np.ndarray,
    c: np.ndarray,
    d: float,
    seed: int,
    extra: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int, float]:
    """One sample, keeping every node whose subtree bound is below ``max(U*, V*) + extra``.

    Returns parent, level, U, Σ arrays of all materialised nodes, the indices of the old and new
    ground states (``-1`` when none was drawn) and ``reach``: every node whose bound lies below it
    is held. Used for drawing a cascade; exact for all states below the threshold. The same search
    as :func:`sample_batch` (``n = 1``, same seed): with ``extra = 0`` it draws exactly the nodes
    that sample does. Stops after :data:`TREE_MAX_NODES` nodes: then ``reach`` is below
    ``max(U*, V*) + extra``, and below ``max(U*, V*)`` when the ground states are not settled.
    """
    _, par, lev, nu, ns, iu, iv, reach = _search(y, sd, T, c, d, 1, seed, TREE_MAX_NODES, extra,
                                                 True, np.inf, np.inf)
    return par.copy(), lev.copy(), nu.copy(), ns.copy(), int(iu), int(iv), float(reach)
