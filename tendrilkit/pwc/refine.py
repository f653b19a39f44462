"""Refinement of the laws on the registered 3D points: Levenberg-Marquardt and the knot score test.

tendrilkit's addition to the paper (:mod:`tendrilkit.pwc` notes,
"Refinement"): the knot values and inner knot positions fitted to the 3D
points with an analytic, compiled Jacobian; and the score test that asks for
one more knot where the residuals call for it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from tendrilkit.frenet import _integrate
from tendrilkit.geometry import _rigid_fit_core
from tendrilkit.pwc.laws import PiecewiseLinearLaw, _pwl_step_means

__all__: list[str] = []


@njit(cache=True)
def _lm_jacobian(s, P, T, B, R, X, Mk, Mt):
    """(3n, p + 6) Jacobian of the registered points (values, then rotation, translation).

    ``Mk, Mt``: (n-1, p) derivatives of the step means per parameter. The laws' columns are
    :func:`_frame_columns` rotated by ``R``; a small rotation ``w`` after ``R`` moves a point by
    ``w x (X - mean X)``, a translation by itself. The refinement itself does not form it
    (:func:`_lm_normal` builds its normal equations); it is the reference its tests check.
    """
    n = P.shape[0]
    nk = Mk.shape[1]
    nt = Mt.shape[1]
    p = nk + nt
    D = _frame_columns(s, P, T, B, Mk, Mt, np.full(n, nk), np.full(n, nt))
    J = np.zeros((3 * n, p + 6))
    for r in range(3 * n):
        j0 = r - r % 3
        for q in range(p):
            d0 = D[j0, q]
            d1 = D[j0 + 1, q]
            d2 = D[j0 + 2, q]
            J[r, q] = R[r % 3, 0] * d0 + R[r % 3, 1] * d1 + R[r % 3, 2] * d2
    m = np.zeros(3)
    for j in range(n):
        for c3 in range(3):
            m[c3] += X[j, c3]
    m /= n
    for j in range(n):
        x = X[j, 0] - m[0]
        y = X[j, 1] - m[1]
        z = X[j, 2] - m[2]
        # small rotation w after R: d = w x X
        J[3 * j + 0, p + 1] = z
        J[3 * j + 0, p + 2] = -y
        J[3 * j + 1, p + 0] = -z
        J[3 * j + 1, p + 2] = x
        J[3 * j + 2, p + 0] = y
        J[3 * j + 2, p + 1] = -x
        J[3 * j + 0, p + 3] = 1.0
        J[3 * j + 1, p + 4] = 1.0
        J[3 * j + 2, p + 5] = 1.0
    return J


@njit(cache=True)
def _frame_columns(s, P, T, B, Mk, Mt, ak, at):
    """(3n, p) columns of :func:`_lm_jacobian` in the integration's frame (not rotated by ``R``).

    ``ak[j]``, ``at[j]``: how many leading columns of ``Mk``, ``Mt`` can be nonzero on the steps
    before point ``j`` (the rest are 0 there and are not visited: the score test's hinges, sorted,
    start one after another); all of them for the laws' columns. One pass over the points, every
    parameter's two running sums updated per step; the sums are kept per component in separate
    arrays and the curvature and torsion parameters in separate loops, so that the loops over
    parameters vectorise. Each entry is written once (the zeros too: no pass over the whole array
    to clear it first).
    """
    n = P.shape[0]
    nk = Mk.shape[1]
    nt = Mt.shape[1]
    p = nk + nt
    D = np.empty((3 * n, p))
    D[:3, :] = 0.0  # the first point does not move
    A0 = np.zeros(p)
    A1 = np.zeros(p)
    A2 = np.zeros(p)
    C0 = np.zeros(p)
    C1 = np.zeros(p)
    C2 = np.zeros(p)
    for j in range(1, n):
        i = j - 1
        h = s[j] - s[i]
        bx = 0.5 * (B[i, 0] + B[j, 0])
        by = 0.5 * (B[i, 1] + B[j, 1])
        bz = 0.5 * (B[i, 2] + B[j, 2])
        tx = 0.5 * (T[i, 0] + T[j, 0])
        ty = 0.5 * (T[i, 1] + T[j, 1])
        tz = 0.5 * (T[i, 2] + T[j, 2])
        mx = 0.5 * (P[i, 0] + P[j, 0])
        my = 0.5 * (P[i, 1] + P[j, 1])
        mz = 0.5 * (P[i, 2] + P[j, 2])
        px = P[j, 0]
        py = P[j, 1]
        pz = P[j, 2]
        r0 = 3 * j
        ek = ak[j]
        et = at[j]
        for q in range(ek):
            c = h * Mk[i, q]
            ax = c * bx
            ay = c * by
            az = c * bz
            A0[q] += ax
            A1[q] += ay
            A2[q] += az
            C0[q] += ay * mz - az * my
            C1[q] += az * mx - ax * mz
            C2[q] += ax * my - ay * mx
        for q in range(et):
            c = h * Mt[i, q]
            ax = c * tx
            ay = c * ty
            az = c * tz
            A0[nk + q] += ax
            A1[nk + q] += ay
            A2[nk + q] += az
            C0[nk + q] += ay * mz - az * my
            C1[nk + q] += az * mx - ax * mz
            C2[nk + q] += ax * my - ay * mx
        for q in range(ek):
            D[r0, q] = A1[q] * pz - A2[q] * py - C0[q]
            D[r0 + 1, q] = A2[q] * px - A0[q] * pz - C1[q]
            D[r0 + 2, q] = A0[q] * py - A1[q] * px - C2[q]
        for q in range(ek, nk):
            D[r0, q] = 0.0
            D[r0 + 1, q] = 0.0
            D[r0 + 2, q] = 0.0
        for q in range(nk, nk + et):
            D[r0, q] = A1[q] * pz - A2[q] * py - C0[q]
            D[r0 + 1, q] = A2[q] * px - A0[q] * pz - C1[q]
            D[r0 + 2, q] = A0[q] * py - A1[q] * px - C2[q]
        for q in range(nk + et, p):
            D[r0, q] = 0.0
            D[r0 + 1, q] = 0.0
            D[r0 + 2, q] = 0.0
    return D


@njit(cache=True)
def _rigid_columns(P, out, o):
    """The registration's six columns in the integration's frame into ``out[:, o:o + 6]``.

    Translations ``e_l``, then rotations ``e_l x y`` about the centroid (``y``: the centred points):
    :func:`_lm_jacobian`'s six columns rotated back by ``R``, for freedoms rotated alike (the same
    span, the same products once rotated back). Every entry of the six columns is written, the zeros
    too (``out`` need not be cleared).
    """
    n = P.shape[0]
    pm0 = pm1 = pm2 = 0.0
    for j in range(n):
        pm0 += P[j, 0]
        pm1 += P[j, 1]
        pm2 += P[j, 2]
    pm0 /= n
    pm1 /= n
    pm2 /= n
    for j in range(n):
        y0 = P[j, 0] - pm0
        y1 = P[j, 1] - pm1
        y2 = P[j, 2] - pm2
        r0 = 3 * j
        out[r0, o] = 1.0
        out[r0 + 1, o] = 0.0
        out[r0 + 2, o] = 0.0
        out[r0, o + 1] = 0.0
        out[r0 + 1, o + 1] = 1.0
        out[r0 + 2, o + 1] = 0.0
        out[r0, o + 2] = 0.0
        out[r0 + 1, o + 2] = 0.0
        out[r0 + 2, o + 2] = 1.0
        # e_0 x y = (0, -y2, y1), e_1 x y = (y2, 0, -y0), e_2 x y = (-y1, y0, 0)
        out[r0, o + 3] = 0.0
        out[r0 + 1, o + 3] = -y2
        out[r0 + 2, o + 3] = y1
        out[r0, o + 4] = y2
        out[r0 + 1, o + 4] = 0.0
        out[r0 + 2, o + 4] = -y0
        out[r0, o + 5] = -y1
        out[r0 + 1, o + 5] = y0
        out[r0 + 2, o + 5] = 0.0


@njit(cache=True)
def _back_rotated_residuals(R, X, data, out):
    """``out[3j:3j + 3] = R^T (X_j - data_j)``: the residuals in the integration's frame."""
    for j in range(X.shape[0]):
        e0 = X[j, 0] - data[j, 0]
        e1 = X[j, 1] - data[j, 1]
        e2 = X[j, 2] - data[j, 2]
        out[3 * j] = R[0, 0] * e0 + R[1, 0] * e1 + R[2, 0] * e2
        out[3 * j + 1] = R[0, 1] * e0 + R[1, 1] * e1 + R[2, 1] * e2
        out[3 * j + 2] = R[0, 2] * e0 + R[1, 2] * e1 + R[2, 2] * e2


@njit(cache=True)
def _lm_normal(s, P, T, B, R, X, data, Mk, Mt):
    """The normal equations ``J^T J`` and ``J^T r`` of :func:`_lm_jacobian`'s Jacobian, without it.

    ``r``: the registered points minus ``data``. The laws' columns are made in the integration's
    frame, unrotated (``R`` is orthogonal: their products are the same, and a residual is rotated
    once instead of every column); the registration's six columns are known in closed form (a
    rotation ``e_k x c`` of the centred points ``c``, a translation ``e_k``), so their products with
    the laws' columns are one product with seven columns in that frame, rotated back, and among
    themselves sums over the points. Returns ``(H, g)``, ``(p + 6, p + 6)`` and ``(p + 6,)``, in
    :func:`_lm_jacobian`'s order (the same to rounding).
    """
    n = P.shape[0]
    nk = Mk.shape[1]
    nt = Mt.shape[1]
    p = nk + nt
    D = _frame_columns(s, P, T, B, Mk, Mt, np.full(n, nk), np.full(n, nt))
    # seven columns in the integration's frame: translations e_l, rotations e_l x y (y: the
    # centred points there), the residuals rotated back R^T r
    W = np.empty((3 * n, 7))
    _rigid_columns(P, W, 0)
    _back_rotated_residuals(R, X, data, W[:, 6])
    xm = np.zeros(3)
    for j in range(n):
        for c3 in range(3):
            xm[c3] += X[j, c3]
    xm /= n
    rs = np.zeros(3)  # sum of the residuals
    cr = np.zeros(3)  # sum of c x r
    cs = np.zeros(3)  # sum of c
    cc = np.zeros((3, 3))  # sum of c c^T
    for j in range(n):
        e0 = X[j, 0] - data[j, 0]
        e1 = X[j, 1] - data[j, 1]
        e2 = X[j, 2] - data[j, 2]
        c0 = X[j, 0] - xm[0]
        c1 = X[j, 1] - xm[1]
        c2 = X[j, 2] - xm[2]
        rs[0] += e0
        rs[1] += e1
        rs[2] += e2
        cr[0] += c1 * e2 - c2 * e1
        cr[1] += c2 * e0 - c0 * e2
        cr[2] += c0 * e1 - c1 * e0
        cs[0] += c0
        cs[1] += c1
        cs[2] += c2
        cc[0, 0] += c0 * c0
        cc[0, 1] += c0 * c1
        cc[0, 2] += c0 * c2
        cc[1, 1] += c1 * c1
        cc[1, 2] += c1 * c2
        cc[2, 2] += c2 * c2
    cc[1, 0] = cc[0, 1]
    cc[2, 0] = cc[0, 2]
    cc[2, 1] = cc[1, 2]
    DT = D.T
    K = DT @ W
    H = np.empty((p + 6, p + 6))
    H[:p, :p] = DT @ D
    g = np.empty(p + 6)
    for q in range(p):
        g[q] = K[q, 6]
        for k in range(3):
            hr = R[k, 0] * K[q, 3] + R[k, 1] * K[q, 4] + R[k, 2] * K[q, 5]
            ht = R[k, 0] * K[q, 0] + R[k, 1] * K[q, 1] + R[k, 2] * K[q, 2]
            H[p + k, q] = hr
            H[q, p + k] = hr
            H[p + 3 + k, q] = ht
            H[q, p + 3 + k] = ht
    c2sum = cc[0, 0] + cc[1, 1] + cc[2, 2]
    for k in range(3):
        for l3 in range(3):
            H[p + k, p + l3] = (c2sum if k == l3 else 0.0) - cc[k, l3]
            H[p + 3 + k, p + 3 + l3] = n if k == l3 else 0.0
    # translation k against rotation l: e_k . (e_l x sum c)
    H[p + 3, p + 0] = 0.0
    H[p + 3, p + 1] = cs[2]
    H[p + 3, p + 2] = -cs[1]
    H[p + 4, p + 0] = -cs[2]
    H[p + 4, p + 1] = 0.0
    H[p + 4, p + 2] = cs[0]
    H[p + 5, p + 0] = cs[1]
    H[p + 5, p + 1] = -cs[0]
    H[p + 5, p + 2] = 0.0
    for k in range(3):
        for l3 in range(3):
            H[p + l3, p + 3 + k] = H[p + 3 + k, p + l3]
        g[p + k] = cr[k]
        g[p + 3 + k] = rs[k]
    return H, g


@njit(cache=True)
def _law_columns(s, knots, values, free_knots):
    """(n-1, p) derivatives of the step means: per value, then per inner knot position.

    A column is 0 on the steps outside its hat's support (its two segments), which are not visited.
    """
    m = knots.shape[0]
    n = s.shape[0]
    p = m + (m - 2 if free_knots else 0)
    G = np.zeros((n - 1, p))
    I = np.empty(n)
    for j in range(m):
        # the step means of the hat of knot j (as _pwl_step_means of the unit vector, the same
        # arithmetic): its integral is 0 up to knots[j-1] and constant from knots[j+1]
        lo = knots[j - 1] if j > 0 else knots[0]
        hi = knots[j + 1] if j < m - 1 else knots[m - 1]
        i0 = 0 if j == 0 else 0.5 * (knots[j] - knots[j - 1]) * (0.0 + 1.0)
        after = i0 + (0.5 * (knots[j + 1] - knots[j]) * (1.0 + 0.0) if j < m - 1 else 0.0)
        # the points from the last at or before lo to the first at or after hi: the integral is
        # constant on either side of them, so the steps there have mean 0
        a = max(np.searchsorted(s, lo, side="right") - 1, 0) if j > 0 else 0
        b = min(np.searchsorted(s, hi, side="left"), n - 1) if j < m - 1 else n - 1
        for i in range(a, b + 1):
            x = s[i]
            if x <= lo and j > 0:
                I[i] = 0.0
            elif x >= hi and j < m - 1:
                I[i] = after
            else:
                x = min(max(x, knots[0]), knots[m - 1])
                if j > 0 and x <= knots[j]:
                    a1 = j - 1  # the rising half: values 0 -> 1
                    d = knots[j] - knots[a1]
                    v = 0.0 + (1.0 - 0.0) * (x - knots[a1]) / d if d > 0 else 0.0
                    I[i] = 0.0 + 0.5 * (x - knots[a1]) * (0.0 + v)
                else:
                    d = knots[j + 1] - knots[j] if j < m - 1 else 0.0
                    v = 1.0 + (0.0 - 1.0) * (x - knots[j]) / d if d > 0 else 1.0
                    I[i] = i0 + 0.5 * (x - knots[j]) * (1.0 + v)
        for i in range(a, b):
            G[i, j] = (I[i + 1] - I[i]) / (s[i + 1] - s[i])
    if free_knots:
        for k in range(1, m - 1):
            t0, t1, t2 = knots[k - 1], knots[k], knots[k + 1]
            # the steps whose midpoint can lie in (t0, t2)
            a = max(np.searchsorted(s, t0, side="left") - 1, 0)
            b = min(np.searchsorted(s, t2, side="right"), n - 1)
            for i in range(a, b):
                x = 0.5 * (s[i] + s[i + 1])
                if t0 < x <= t1:
                    G[i, m + k - 1] = -(values[k] - values[k - 1]) * (x - t0) / (t1 - t0) ** 2
                elif t1 < x < t2:
                    G[i, m + k - 1] = -(values[k + 1] - values[k]) * (t2 - x) / (t2 - t1) ** 2
    return G


@njit(cache=True)
def _lm_evaluate(s, kk, vk, kt, vt, data):
    P, T, _, B = _integrate(s, _pwl_step_means(s, kk, vk), _pwl_step_means(s, kt, vt), np.eye(3), np.zeros(3), False)
    if not np.all(np.isfinite(P)):
        return np.inf, P, T, B, np.eye(3), P.copy()
    R, t = _rigid_fit_core(P, data)
    X = P @ R.T
    f = 0.0
    for j in range(X.shape[0]):
        for c in range(3):
            X[j, c] += t[c]
            d = X[j, c] - data[j, c]
            f += d * d
    return f, P, T, B, R, X


@njit(cache=True)
def _unpack_nb(q, kk, kt, free_knots):
    mk, mt = kk.shape[0], kt.shape[0]
    kk2 = kk.copy()
    kt2 = kt.copy()
    vk = q[:mk].copy()
    o = mk
    if free_knots and mk > 2:
        kk2[1:mk - 1] = q[o:o + mk - 2]
        o += mk - 2
    vt = q[o:o + mt].copy()
    o += mt
    if free_knots and mt > 2:
        kt2[1:mt - 1] = q[o:o + mt - 2]
    return kk2, vk, kt2, vt


@njit(cache=True)
def _min_gap_of(k):
    g = np.inf
    for i in range(k.shape[0] - 1):
        g = min(g, k[i + 1] - k[i])
    return g


@njit(cache=True)
def _value_caps(knots, L, out):
    """Largest step of each knot value: the law may turn the frame by about 1 rad more per step.

    A value's hat spans its two neighbouring segments (width ``w``): changing it by
    ``d`` turns the frame by about ``d w / 2`` over that span, so ``1 / w``, and never less
    than ``1 / L`` (a law of one segment).
    """
    m = knots.shape[0]
    for j in range(m):
        w = knots[min(j + 1, m - 1)] - knots[max(j - 1, 0)]
        out[j] = max(1.0 / L, 1.0 / w) if w > 0 else 1.0 / L


@njit(cache=True)
def _gap_fraction(knots, inner_step, gap):
    """Largest fraction (<= 1) of a step of the inner knots keeping consecutive knots ``gap`` apart (0.99 of it)."""
    m = knots.shape[0]
    if inner_step.shape[0] == 0:
        return 1.0
    a = 1.0
    for i in range(m - 1):
        d0 = inner_step[i - 1] if i > 0 else 0.0
        d1 = inner_step[i] if i < m - 2 else 0.0
        closing = d0 - d1
        if closing > 0:
            room = knots[i + 1] - knots[i] - gap
            a = min(a, 0.99 * max(room, 0.0) / closing)
    return a


@njit(cache=True)
def _spd_solve(A, b, L, x):
    """``x`` solving ``A x = b`` for a symmetric positive definite ``A`` by Cholesky (``L`` a work array
    of A's shape); False, and ``x`` untouched, where a pivot is not positive (the caller solves otherwise).

    The damped normal equations are positive definite; at their size (10-30) this is a fraction of
    LAPACK's general solve, its copies and its pivoting.
    """
    m = A.shape[0]
    for j in range(m):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        d = np.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, m):
            v = A[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / d
    for i in range(m):  # L y = b
        v = b[i]
        for k in range(i):
            v -= L[i, k] * x[k]
        x[i] = v / L[i, i]
    for i in range(m - 1, -1, -1):  # L^T x = y
        v = x[i]
        for k in range(i + 1, m):
            v -= L[k, i] * x[k]
        x[i] = v / L[i, i]
    return True


@njit(cache=True)
def _lm_from(s, data, kk, vk, kt, vt, free_knots, min_gap, iterations, rtol, f, P, T, B, R, X):
    """Levenberg-Marquardt from the evaluation ``f, P, T, B, R, X`` of the start (:func:`_lm_evaluate`'s).

    Returns the refined ``kk, vk, kt, vt``, their SSE and their evaluation ``P, T, B, R, X`` (the
    same bits as :func:`_lm_evaluate` of the returned laws: the one that accepted them, or the start's).
    """
    mk, mt = kk.shape[0], kt.shape[0]
    ik = mk - 2 if (free_knots and mk > 2) else 0
    it = mt - 2 if (free_knots and mt > 2) else 0
    npar = mk + ik + mt + it
    p = np.empty(npar)
    p[:mk] = vk
    p[mk:mk + ik] = kk[1:mk - 1][:ik]
    p[mk + ik:mk + ik + mt] = vt
    p[mk + ik + mt:] = kt[1:mt - 1][:it]
    is_knot = np.zeros(npar, dtype=np.bool_)
    is_knot[mk:mk + ik] = True
    is_knot[mk + ik + mt:] = True
    L = s[-1] - s[0]
    max_knot_step = 0.1 * L
    cap = np.empty(npar)
    gap_k = max(min(min_gap, 0.5 * _min_gap_of(kk)), 1e-6 * L)
    gap_t = max(min(min_gap, 0.5 * _min_gap_of(kt)), 1e-6 * L)
    ck = _unpack_nb(p, kk, kt, free_knots)  # the start's values: its evaluation is f, P, T, B, R, X
    mu = 1e-4
    if not np.isfinite(f):
        return ck[0], ck[1], ck[2], ck[3], f, P, T, B, R, X
    for _ in range(iterations):
        Gk = _law_columns(s, ck[0], ck[1], free_knots)
        Gt = _law_columns(s, ck[2], ck[3], free_knots)
        H, g = _lm_normal(s, P, T, B, R, X, data, Gk, Gt)
        m = H.shape[0]
        tr = 0.0
        for i in range(m):
            tr += H[i, i]
        improved = False
        fq = f
        q = p
        cq = ck
        Pq, Tq, Bq, Rq, Xq = P, T, B, R, X
        if not np.all(np.isfinite(H)) or not np.all(np.isfinite(g)):
            break
        _value_caps(ck[0], L, cap[:mk])
        _value_caps(ck[2], L, cap[mk + ik:mk + ik + mt])
        mg = -g
        Lw = np.empty((m, m))
        full = np.empty(m)
        for _ in range(12):
            if mu > 1e12:
                break
            A = H.copy()
            for i in range(m):
                A[i, i] += mu * (H[i, i] + 1e-12 * tr + 1e-300)
            if _spd_solve(A, mg, Lw, full):
                step = full[:npar].copy()
            else:
                step = np.linalg.solve(A, mg)[:npar]
            ok = True
            for i in range(npar):
                v = step[i]
                if not np.isfinite(v):
                    ok = False
                else:  # a step beyond a parameter's reach is clipped to it
                    c = max_knot_step if is_knot[i] else cap[i]
                    step[i] = min(max(v, -c), c)
            if not ok:
                mu *= 10.0
                continue
            # knots that would come closer than the gap: their steps shortened to keep them apart
            step[mk:mk + ik] *= _gap_fraction(ck[0], step[mk:mk + ik], gap_k)
            step[mk + ik + mt:] *= _gap_fraction(ck[2], step[mk + ik + mt:], gap_t)
            q = p + step
            cq = _unpack_nb(q, kk, kt, free_knots)
            if _min_gap_of(cq[0]) < gap_k or _min_gap_of(cq[2]) < gap_t:
                mu *= 10.0
                continue
            fq, Pq, Tq, Bq, Rq, Xq = _lm_evaluate(s, cq[0], cq[1], cq[2], cq[3], data)
            if np.isfinite(fq) and fq < f:
                improved = True
                break
            mu *= 10.0
        if not improved:
            break
        rel = (f - fq) / max(f, 1e-300)
        p, ck, P, T, B, R, X, f = q, cq, Pq, Tq, Bq, Rq, Xq, fq
        mu = max(mu / 10.0, 1e-12)
        if rel < rtol:
            break
    return ck[0], ck[1], ck[2], ck[3], f, P, T, B, R, X


@njit(cache=True)
def _same_numbers(a, b):
    """Do the float arrays ``a`` and ``b`` hold the same numbers (zeros of the same sign; NaN: never)?"""
    if a.shape[0] != b.shape[0]:
        return False
    for i in range(a.shape[0]):
        if not (a[i] == b[i] and np.copysign(1.0, a[i]) == np.copysign(1.0, b[i])):
            return False
    return True


@njit(cache=True)
def _refine_best(s, data, knots_k, ends_k, values_k, knots_t, ends_t, values_t, free_knots, min_gap, iterations,
                 rtol, have_state, f, P, T, B, R, X):
    """The best of several starts refined: one compiled call for a candidate of the search.

    Start ``i`` is the laws ``knots_k[ends_k[i]:ends_k[i + 1]]`` (values ``values_k`` alike) and
    ``knots_t[ends_t[i]:ends_t[i + 1]]``. Each start is evaluated (:func:`_lm_evaluate`; with
    ``have_state`` and one start, ``f, P, T, B, R, X`` is its evaluation, not computed again), the
    first of least SSE is refined (:func:`_lm_from`, ``iterations`` 0: not refined). A start that repeats
    an earlier one (the same numbers: the search's union of knot sets is often the new set itself) is
    not evaluated again: its SSE would be the earlier one's, and a later start is taken only for less.
    Returns the index of the start refined, then :func:`_lm_from`'s results: the same bits as those
    functions called one by one.
    """
    best = -1
    m = ends_k.shape[0] - 1
    if not (have_state and m == 1):
        for i in range(m):
            a0, a1, b0, b1 = ends_k[i], ends_k[i + 1], ends_t[i], ends_t[i + 1]
            repeat = False
            for j in range(i):
                c0, c1, d0, d1 = ends_k[j], ends_k[j + 1], ends_t[j], ends_t[j + 1]
                if (_same_numbers(knots_k[a0:a1], knots_k[c0:c1]) and _same_numbers(values_k[a0:a1], values_k[c0:c1])
                        and _same_numbers(knots_t[b0:b1], knots_t[d0:d1])
                        and _same_numbers(values_t[b0:b1], values_t[d0:d1])):
                    repeat = True
                    break
            if repeat:
                continue
            fi, Pi, Ti, Bi, Ri, Xi = _lm_evaluate(s, knots_k[a0:a1], values_k[a0:a1], knots_t[b0:b1],
                                                  values_t[b0:b1], data)
            if best < 0 or fi < f:
                best, f, P, T, B, R, X = i, fi, Pi, Ti, Bi, Ri, Xi
    else:
        best = 0
    a0, a1, b0, b1 = ends_k[best], ends_k[best + 1], ends_t[best], ends_t[best + 1]
    kk2, vk2, kt2, vt2, sse, P, T, B, R, X = _lm_from(
        s, data, knots_k[a0:a1].copy(), values_k[a0:a1].copy(), knots_t[b0:b1].copy(), values_t[b0:b1].copy(),
        free_knots, min_gap, iterations, rtol, f, P, T, B, R, X)
    return best, kk2, vk2, kt2, vt2, sse, P, T, B, R, X


_NO_STATE = (np.inf, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.eye(3), np.zeros((0, 3)))


def _refine_starts(s, data, starts, *, free_knots, min_gap, iterations, rtol, state=None):
    """The first of ``starts`` (pairs of laws) of least SSE, refined (:func:`_refine_best`).

    Returns its index in ``starts``, the refined laws' arrays ``(kk, vk, kt, vt)``, their SSE and
    their :func:`_law_state` (the evaluation the iterations ended on). ``state``: the evaluation of
    the only start, if known.
    """
    c = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    if len(starts) == 1:
        (lk, lt), = starts
        kk, vk, kt, vt = c(lk.knots_mm), c(lk.values), c(lt.knots_mm), c(lt.values)
        ek, et = np.array([0, kk.size]), np.array([0, kt.size])
    else:  # the laws' arrays end to end (np.concatenate makes float arrays of float ones, contiguous)
        kk = np.concatenate([a.knots_mm for a, _ in starts], dtype=float)
        vk = np.concatenate([a.values for a, _ in starts], dtype=float)
        kt = np.concatenate([b.knots_mm for _, b in starts], dtype=float)
        vt = np.concatenate([b.values for _, b in starts], dtype=float)
        ek = np.zeros(len(starts) + 1, dtype=np.int64)
        et = np.zeros(len(starts) + 1, dtype=np.int64)
        for i, (a, b) in enumerate(starts):
            ek[i + 1] = ek[i] + a.knots_mm.size
            et[i + 1] = et[i] + b.knots_mm.size
    have = state is not None and len(starts) == 1
    best, kk2, vk2, kt2, vt2, sse, P, T, B, R, X = _refine_best(
        s, data, kk, ek, vk, kt, et, vt, bool(free_knots), float(min_gap), int(iterations), float(rtol), have,
        *(state if have else _NO_STATE))
    return int(best), (kk2, vk2, kt2, vt2), float(sse), (float(sse), P, T, B, R, X)


def _refine_laws_lm(s, data, kk, vk, kt, vt, *, free_knots=True, min_gap=1.0, iterations=40, rtol=1e-6, state=None):
    """Levenberg-Marquardt on the knot values (and inner knot positions), compiled.

    Residuals are the registered 3D errors. The Jacobian is analytic: a change
    :math:`\\delta` of the curvature over step ``i`` rotates the rest of the
    curve about :math:`B_i` through the step by :math:`h_i \\delta` (torsion:
    about :math:`T_i`), so :math:`\\partial P_j = \\sum_{i<j} h_i \\delta_i
    D_i \\times (P_j - P_i)`, two running sums; a parameter moves the step
    means through :func:`_law_columns`. The rigid registration's six freedoms
    are part of each step (variable projection). Each iteration changes a
    value by at most 1/L and a knot by at most L/10 (the reach of the linear
    model; a longer step raises the damping); knots stay ``min_gap`` mm
    apart. Stops when an iteration lowers the SSE by less than the fraction
    ``rtol``. ``state``: the start's :func:`_law_state`, if the caller has it
    (the start is then not evaluated again; the same bits). Returns the laws' arrays, their SSE and
    their :func:`_law_state` (the evaluation the iterations ended on).
    """
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    kk, vk, kt, vt = f(kk), f(vk), f(kt), f(vt)
    _, kk2, vk2, kt2, vt2, sse, P, T, B, R, X = _refine_best(
        f(s), f(data), kk, np.array([0, kk.size]), vk, kt, np.array([0, kt.size]), vt, bool(free_knots),
        float(min_gap), int(iterations), float(rtol), state is not None, *(_NO_STATE if state is None else state))
    return (kk2, vk2, kt2, vt2), float(sse), (float(sse), P, T, B, R, X)


def _refine_laws(prep, law_k, law_t, iterations=40, rtol=1e-6, state=None):
    """The laws refined on ``prep``'s points: ``(law_k, law_t, sse_mm2, end)``.

    ``end`` is the refined laws' :func:`_law_state` (the same bits), where a further refinement
    of them or their score test (:func:`_best_insertions`) can start without evaluating them again.
    """
    s = prep.s
    (kk, vk, kt, vt), sse, end = _refine_laws_lm(
        s, prep.data, law_k.knots_mm, law_k.values, law_t.knots_mm, law_t.values,
        free_knots=prep.free_knots, min_gap=prep.min_gap_mm, iterations=iterations, rtol=rtol, state=state)
    return PiecewiseLinearLaw(kk, vk, "kappa"), PiecewiseLinearLaw(kt, vt, "tau"), sse, end


def _law_state(prep, law_k, law_t):
    """The laws integrated from the identity and registered onto ``prep.data``: ``(sse, P, T, B, R, X)``.

    :func:`_lm_evaluate`'s evaluation, which is where :func:`_refine_laws` starts (``state``): the
    automatic selection compares its starts by this SSE and refines the best from it.
    """
    return _refine_starts(prep.s, prep.data, [(law_k, law_t)], free_knots=prep.free_knots, min_gap=prep.min_gap_mm,
                          iterations=0, rtol=0.0)[3]


@njit(cache=True)
def _hinge_means(s, xs):
    """(n-1, m) step means of the hinges :math:`(s - x)_+` for the m positions ``xs``, mm."""
    n = s.shape[0]
    G = np.empty((n - 1, xs.shape[0]))
    for i in range(n - 1):
        a = s[i]
        b = s[i + 1]
        for q in range(xs.shape[0]):
            x = xs[q]
            if b <= x:
                G[i, q] = 0.0
            elif a >= x:
                G[i, q] = 0.5 * (a + b) - x
            else:
                d = b - x
                G[i, q] = d * d / (2 * (b - a))
    return G


def _hinge_positions(prep, lk, lt):
    """The positions the score test tries (mm) and, per law, those at least the minimum gap from its knots."""
    s, gap = prep.s, prep.min_gap_mm
    xs = prep.hinge_xs_mm
    if xs is None:
        xs = np.arange(s[0] + gap, s[-1] - gap, max(gap / 2, (s[-1] - s[0]) / 200))
    # np.minimum.reduce: np.min's reduction without its wrapper (called for every step of a search)
    return xs, [np.minimum.reduce(np.abs(xs[:, None] - law.knots_mm[None, :]), axis=1) >= gap for law in (lk, lt)]


def _best_insertions(prep, lk, lt, state=None):
    """Score test for one more knot: the best new knot position for each law.

    At the refined fit, adding a knot at ``x`` adds the hinge :math:`(s - x)_+`
    to the law's span; the first-order drop of the 3D SSE is
    :math:`(c_\\perp^T r)^2 / |c_\\perp|^2` with :math:`c` the hinge's
    Jacobian column made orthogonal to the current ones. Returns
    ``(x_kappa, gain_kappa), (x_tau, gain_tau)`` (``None`` where no room). ``state``: the laws'
    :func:`_law_state`, if the caller has it (not evaluated again; the same bits).
    """
    s, data = prep.s, prep.data
    xs, oks = _hinge_positions(prep, lk, lt)
    if not (oks[0].any() or oks[1].any()):
        return [None, None]
    if state is None:
        state = _law_state(prep, lk, lt)
    f, P, T, B, R, X = state
    c = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    gain = _score_gains(s, data, P, T, B, R, X, c(lk.knots_mm), c(lk.values), c(lt.knots_mm), c(lt.values),
                        bool(prep.free_knots), xs[oks[0]], xs[oks[1]])
    out = []
    for ok, g in zip(oks, gain):
        if not ok.any():
            out.append(None)
            continue
        j = int(np.argmax(g))
        out.append((float(xs[ok][j]), float(g[j])))
    return out


@njit(cache=True)
def _score_gains(s, data, P, T, B, R, X, kk, vk, kt, vt, free_knots, xk, xt):
    """The score test's first-order SSE drops of the hinges at ``xk`` (curvature) and ``xt`` (torsion).

    :func:`_best_insertions`'s arithmetic in one compiled call: the Jacobian of the current laws
    column-scaled, each hinge's column projected off it through the (ridged) normal equations,
    gain :math:`(c_\\perp^T r)^2 / |c_\\perp|^2`. All in the integration's frame (:func:`_frame_columns`;
    the registration's freedoms rotated alike, the same span): gains the same to rounding. ``xk``,
    ``xt`` increasing. Returns the two laws' gains, (len(xk),) and (len(xt),).
    """
    n = P.shape[0]
    Gk = _law_columns(s, kk, vk, free_knots)
    Gt = _law_columns(s, kt, vt, free_knots)
    D = _frame_columns(s, P, T, B, Gk, Gt, np.full(n, Gk.shape[1]), np.full(n, Gt.shape[1]))
    rows, pl = D.shape
    p = pl + 6
    J = np.empty((rows, p))
    J[:, :pl] = D
    _rigid_columns(P, J, pl)
    sc = np.zeros(p)
    for i in range(rows):
        for q in range(p):
            sc[q] += J[i, q] * J[i, q]
    for q in range(p):
        sc[q] = 1.0 / (np.sqrt(sc[q]) + 1e-300)
    for i in range(rows):
        for q in range(p):
            J[i, q] *= sc[q]
    JT = J.T
    H = JT @ J
    for q in range(p):
        H[q, q] += 1e-10
    u = np.empty(rows)
    _back_rotated_residuals(R, X, data, u)
    nk, nt = xk.shape[0], xt.shape[0]
    # both laws' hinge columns in one pass; a hinge moves the points after it only
    C = _frame_columns(s, P, T, B, _hinge_means(s, xk), _hinge_means(s, xt), np.searchsorted(xk, s),
                       np.searchsorted(xt, s))
    JY = J @ np.linalg.solve(H, JT @ C)  # the hinges' columns projected off C_perp = C - JY
    num = np.zeros(nk + nt)
    den = np.zeros(nk + nt)
    for i in range(rows):
        ui = u[i]
        for q in range(nk + nt):
            v = C[i, q] - JY[i, q]
            num[q] += v * ui
            den[q] += v * v
    gk = np.empty(nk)
    gt = np.empty(nt)
    for q in range(nk + nt):
        g = num[q] * num[q] / (den[q] + 1e-300)
        if q < nk:
            gk[q] = g
        else:
            gt[q - nk] = g
    return gk, gt
