"""Every inverse-kinematics solution of a general 6R arm, by Raghavan-Roth elimination.

The method (Raghavan & Roth 1993, Manocha & Canny 1994; the problem of seed 004), without any
symbolic preprocessing:

1. Rotate each joint frame so that every joint turns about its local z. The arm is then the loop
   ``Z(p0) K0 Z(p1) K1 ... Z(p5) K5 = I`` with ``Z(p)`` a rotation about z by joint angle ``p``
   and ``K5`` holding the target pose.
2. Split it as ``K1 Z(p2) K2 Z(p3) K3 Z(p4) K4 = Z(-p1) K0^-1 Z(-p0) K5^-1 Z(-p5)``. The z axis
   ``l`` and origin ``p`` of both sides do not depend on ``p5``. From them the 14 Raghavan-Roth
   quantities (``l, p, p.p, p.l, p x l, (p.p) l - 2 (p.l) p``) are trigonometric polynomials of
   degree one in each angle. Their coefficients are *measured*, not derived: the quantities are
   evaluated on the 3-point grids {0, 120, 240} deg of each angle and the grid is inverted
   exactly. The left side depends on the arm only and is measured once per arm.
3. Eliminating the eight products of ``p0, p1`` (left null space of their 14x8 coefficient
   matrix) leaves six equations bilinear in the half-angle monomials of ``p3, p4`` with
   coefficients linear in ``cos p2, sin p2``; multiplied by ``tan(p3/2)`` they become the 12x12
   matrix ``M(p2)``. Its determinant is a trigonometric polynomial of degree 8 in ``p2``
   (sixteen roots, the known bound), measured by 18 samples and a discrete Fourier transform.
4. Real roots: sign changes on a 360-point grid, refined by safeguarded Newton; a grid cell
   holding two close roots or a double root shows as a small local extremum, which is resolved
   by its local quadratic and reported as near-double.
5. Per root, the null vector of ``M(p2)`` gives ``p3, p4``; the eliminated products give
   ``p0, p1``; the loop gives ``p5``. Every candidate is refined by Newton steps on the full
   pose and kept only if forward kinematics reproduces the target.

If a split is degenerate for the arm or the pose (a rank-deficient product matrix or a
determinant that vanishes identically, as for some special geometries), the loop is rotated or
reversed (twelve splits) until one is regular; the result says which one served.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.compiled import CompiledSolver, KernelOutput, padded_outputs
from armpath.ik.kernels import (
    copy_system,
    fk_error_jacobian,
    keep_solution,
    lu_solve_into,
    scan_tables,
    sort_solutions,
    trig_roots,
)
from armpath.ik.result import chain_length_scale
from armpath.jit import njit, prange, threads_pay_off
from armpath.kinematics import _affine_mul, copy_into, z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]

_CAP = 24  # candidate slots (a few spare for near-double pairs before de-duplication)
_GRID: FloatArray = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
_BASIS = np.stack([np.ones(3), np.cos(_GRID), np.sin(_GRID)], axis=1)  # [sample, harmonic]
_BASIS_INV = np.linalg.inv(_BASIS)  # harmonic coefficients = _BASIS_INV @ samples
#: (1 + x^2) * {1, cos, sin} of the half-angle x = tan(p/2), as coefficients of x^0, x^1, x^2.
_HALF = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]])
_HALF2: FloatArray = np.asarray(np.kron(_HALF, _HALF), dtype=np.float64)
_N_DET = 18  # determinant samples: 17 harmonics of the degree-8 polynomial (9..12 vanish)
_N_SCAN = 360  # root-scan grid
_SCAN, _SCAN_COS, _SCAN_SIN = scan_tables(_N_SCAN, 9)
_DET_PHI: FloatArray = np.asarray(np.arange(_N_DET) * (2.0 * np.pi / _N_DET), dtype=np.float64)
#: Fixed offsets of the three left-side angles (rad): keep half-angle monomials finite.
DEFAULT_DELTAS = np.array([0.7123, -1.1379, 0.4518])


@njit(cache=True)
def _mm(A: FloatArray, B: FloatArray) -> FloatArray:
    """Product of two 4x4 rigid transforms as a new array (:func:`_affine_mul`)."""
    out = np.empty((4, 4))
    _affine_mul(A, B, out)
    return out


@njit(cache=True)
def _mrz(A: FloatArray, phi: float) -> FloatArray:
    """``A @ Rz(phi)`` for a 4x4 rigid transform."""
    c, s = np.cos(phi), np.sin(phi)
    out = A.copy()
    for i in range(3):
        out[i, 0] = A[i, 0] * c + A[i, 1] * s
        out[i, 1] = -A[i, 0] * s + A[i, 1] * c
    return out


@njit(cache=True)
def _rigid_inv(T: FloatArray) -> FloatArray:
    out = np.zeros((4, 4))
    for i in range(3):
        for j in range(3):
            out[i, j] = T[j, i]
        out[i, 3] = -(T[0, i] * T[0, 3] + T[1, i] * T[1, 3] + T[2, i] * T[2, 3])
    out[3, 3] = 1.0
    return out


@njit(cache=True)
def _quantities(l: FloatArray, p: FloatArray, out: FloatArray) -> None:  # noqa: E741
    """The 14 Raghavan-Roth quantities of the line (direction l, point p)."""
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    pl = p[0] * l[0] + p[1] * l[1] + p[2] * l[2]
    for k in range(3):
        out[k] = l[k]
        out[3 + k] = p[k]
        out[11 + k] = pp * l[k] - 2.0 * pl * p[k]
    out[6] = pp
    out[7] = pl
    out[8] = p[1] * l[2] - p[2] * l[1]
    out[9] = p[2] * l[0] - p[0] * l[2]
    out[10] = p[0] * l[1] - p[1] * l[0]


@njit(cache=True)
def lhs_coefficients(
    D: FloatArray, deltas: FloatArray, grid: FloatArray, basis_inv: FloatArray
) -> FloatArray:
    """Coefficients ``P[h2, q, h3 * 3 + h4]`` of the left side ``D0 Z D1 Z D2 Z D3``.

    ``h`` indexes the harmonics {1, cos, sin} of ``p_k - delta_k``; ``q`` the 14 quantities.
    """
    F = np.empty((3, 3, 3, 14))
    for i in range(3):
        A = _mm(_mrz(D[0], grid[i] + deltas[0]), D[1])
        for j in range(3):
            B = _mm(_mrz(A, grid[j] + deltas[1]), D[2])
            for k in range(3):
                M = _mm(_mrz(B, grid[k] + deltas[2]), D[3])
                _quantities(
                    np.ascontiguousarray(M[:3, 2]), np.ascontiguousarray(M[:3, 3]), F[i, j, k]
                )
    P = np.zeros((3, 14, 9))
    for a in range(3):
        for b in range(3):
            for c in range(3):
                for i in range(3):
                    for j in range(3):
                        for k in range(3):
                            w = basis_inv[a, i] * basis_inv[b, j] * basis_inv[c, k]
                            if w != 0.0:
                                for q in range(14):
                                    P[a, q, b * 3 + c] += w * F[i, j, k, q]
    return P


@njit(cache=True)
def _rhs_coefficients(
    E1: FloatArray,
    lE: FloatArray,
    pE: FloatArray,
    grid: FloatArray,
    basis_inv: FloatArray,
    G: FloatArray,
    R: FloatArray,
) -> None:
    """Coefficients ``R[q, h0 * 3 + h1]`` of ``Z(-p1) E1 Z(-p0)`` applied to the line (lE, pE);
    ``G`` is a (3, 3, 14) work array."""
    lv = np.empty(3)
    pv = np.empty(3)
    for i in range(3):
        c0, s0 = np.cos(grid[i]), np.sin(grid[i])
        # Z(-p0) then E1: direction and point in E1's frame.
        l0, l1 = c0 * lE[0] + s0 * lE[1], -s0 * lE[0] + c0 * lE[1]
        x0, x1 = c0 * pE[0] + s0 * pE[1], -s0 * pE[0] + c0 * pE[1]
        la = E1[0, 0] * l0 + E1[0, 1] * l1 + E1[0, 2] * lE[2]
        lb = E1[1, 0] * l0 + E1[1, 1] * l1 + E1[1, 2] * lE[2]
        lc = E1[2, 0] * l0 + E1[2, 1] * l1 + E1[2, 2] * lE[2]
        pa = E1[0, 0] * x0 + E1[0, 1] * x1 + E1[0, 2] * pE[2] + E1[0, 3]
        pb = E1[1, 0] * x0 + E1[1, 1] * x1 + E1[1, 2] * pE[2] + E1[1, 3]
        pc = E1[2, 0] * x0 + E1[2, 1] * x1 + E1[2, 2] * pE[2] + E1[2, 3]
        for j in range(3):
            c1, s1 = np.cos(grid[j]), np.sin(grid[j])
            lv[0] = c1 * la + s1 * lb
            lv[1] = -s1 * la + c1 * lb
            lv[2] = lc
            pv[0] = c1 * pa + s1 * pb
            pv[1] = -s1 * pa + c1 * pb
            pv[2] = pc
            _quantities(lv, pv, G[i, j])
    R[:, :] = 0.0
    for a in range(3):
        for b in range(3):
            for i in range(3):
                for j in range(3):
                    w = basis_inv[a, i] * basis_inv[b, j]
                    if w != 0.0:
                        for q in range(14):
                            R[q, a * 3 + b] += w * G[i, j, q]


@njit(cache=True)
def _pencil_at(Mh: FloatArray, phi: float, out: FloatArray) -> None:
    """``out = Mh[0] + cos(phi) Mh[1] + sin(phi) Mh[2]`` without temporaries."""
    c, s = np.cos(phi), np.sin(phi)
    n = out.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = Mh[0, i, j] + c * Mh[1, i, j] + s * Mh[2, i, j]


@njit(cache=True)
def _det_lu(A: FloatArray) -> float:
    """Determinant by LU with partial pivoting (A is overwritten)."""
    n = A.shape[0]
    det = 1.0
    for k in range(n):
        piv = k
        big = abs(A[k, k])
        for r in range(k + 1, n):
            if abs(A[r, k]) > big:
                big = abs(A[r, k])
                piv = r
        if big == 0.0:
            return 0.0
        if piv != k:
            for c in range(n):
                tmp = A[k, c]
                A[k, c] = A[piv, c]
                A[piv, c] = tmp
            det = -det
        det *= A[k, k]
        inv = 1.0 / A[k, k]
        for r in range(k + 1, n):
            f = A[r, k] * inv
            if f != 0.0:
                for c in range(k + 1, n):
                    A[r, c] -= f * A[k, c]
    return det


@njit(cache=True)
def _householder(A: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Householder QR of a tall matrix (overwritten): reflector vectors, their betas and R."""
    m, n = A.shape
    V = np.zeros((n, m))
    beta = np.zeros(n)
    for k in range(n):
        normx = 0.0
        for i in range(k, m):
            normx += A[i, k] * A[i, k]
        normx = np.sqrt(normx)
        if normx == 0.0:
            continue
        alpha = -normx if A[k, k] >= 0.0 else normx
        vn = 0.0
        for i in range(k, m):
            V[k, i] = A[i, k]
        V[k, k] -= alpha
        for i in range(k, m):
            vn += V[k, i] * V[k, i]
        if vn == 0.0:
            continue
        beta[k] = 2.0 / vn
        for j in range(k, n):
            w = 0.0
            for i in range(k, m):
                w += V[k, i] * A[i, j]
            w *= beta[k]
            for i in range(k, m):
                A[i, j] -= w * V[k, i]
    R = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            R[i, j] = A[i, j]
    return V, beta, R


@njit(cache=True)
def _reflect(V: FloatArray, beta: FloatArray, x: FloatArray, transpose: bool) -> None:
    """x <- H^T x (transpose) or H x, with H = H_0 H_1 ... H_{n-1} the Householder product."""
    n, m = V.shape
    for step in range(n):
        k = step if transpose else n - 1 - step
        w = 0.0
        for i in range(m):
            w += V[k, i] * x[i]
        w *= beta[k]
        for i in range(m):
            x[i] -= w * V[k, i]


@njit(cache=True)
def _null_vector(A: FloatArray, cols: NDArray[np.int64], y: FloatArray, out: FloatArray) -> None:
    """Unit null vector (approximate) of a (near-)singular square matrix into ``out``, by
    complete-pivoting LU (A is overwritten; ``cols``, ``y`` are work arrays of its size)."""
    n = A.shape[0]
    for k in range(n):
        cols[k] = k
    for k in range(n):
        pr, pc, big = k, k, -1.0
        for r in range(k, n):
            for c in range(k, n):
                if abs(A[r, c]) > big:
                    big = abs(A[r, c])
                    pr, pc = r, c
        if pr != k:
            for c in range(n):
                tmp = A[k, c]
                A[k, c] = A[pr, c]
                A[pr, c] = tmp
        if pc != k:
            for r in range(n):
                tmp = A[r, k]
                A[r, k] = A[r, pc]
                A[r, pc] = tmp
            t = cols[k]
            cols[k] = cols[pc]
            cols[pc] = t
        if big == 0.0:
            break
        inv = 1.0 / A[k, k]
        for r in range(k + 1, n):
            f = A[r, k] * inv
            if f != 0.0:
                for c in range(k + 1, n):
                    A[r, c] -= f * A[k, c]
    # Null vector of U: last (permuted) component 1, back substitution over the rest.
    y[n - 1] = 1.0
    for k in range(n - 2, -1, -1):
        s = 0.0
        for c in range(k + 1, n):
            s += A[k, c] * y[c]
        y[k] = -s / A[k, k] if A[k, k] != 0.0 else 0.0
    norm = 0.0
    for k in range(n):
        norm += y[k] * y[k]
    norm = np.sqrt(norm)
    for k in range(n):
        out[cols[k]] = y[k] / norm


_ALL_REVOLUTE = np.zeros(6, dtype=np.bool_)


@njit(cache=True)
def _refine(
    C: FloatArray,
    T: FloatArray,
    q: FloatArray,
    iterations: int,
    q_known: FloatArray,
    deflate: bool,
    scratch: FloatArray,
) -> tuple[float, float, float]:
    """Newton steps on the pose; returns (position error, rotation error, Jacobian ratio).

    Steps are clamped to 0.3 rad. With ``deflate`` the residual is divided by the distance to
    ``q_known`` (Brown / Farrell deflation), so that Newton finds a *second* solution next to a
    known one, which is how a near-double pair is split. ``scratch``: a (3, 6, 6) work array.
    """
    J = scratch[0]
    Jw = scratch[1]
    err = scratch[2, 0]
    ew = scratch[2, 1]
    dq = scratch[2, 2]
    ratio = 0.0
    previous = np.inf
    for _ in range(iterations):
        fk_error_jacobian(C, _ALL_REVOLUTE, q, T, err, J)
        size = 0.0
        for i in range(6):
            size += err[i] * err[i]
        size = np.sqrt(size)
        if size < 1e-14 or (size < 1e-11 and size > 0.25 * previous):
            break  # converged, or stalled at rounding level
        previous = size
        copy_system(J, err, Jw, ew)
        if lu_solve_into(Jw, ew, dq) == 0.0:
            break
        if deflate:
            r2 = 0.0
            dot = 0.0
            for i in range(6):
                diff = q[i] - q_known[i]
                r2 += diff * diff
                dot += diff * dq[i]
            if r2 < 1e-30:
                break
            m = 1.0 / r2 + 1.0
            denom = 1.0 + 2.0 * dot / (r2 * r2) / m
            if abs(denom) > 1e-12:
                for i in range(6):
                    dq[i] /= denom
        norm = 0.0
        for i in range(6):
            norm += dq[i] * dq[i]
        norm = np.sqrt(norm)
        shrink = 0.3 / norm if norm > 0.3 else 1.0
        for i in range(6):
            q[i] += shrink * dq[i]
        if norm < 1e-14:
            break
    fk_error_jacobian(C, _ALL_REVOLUTE, q, T, err, J)
    norms = 1.0
    for i in range(6):
        col = 0.0
        for r in range(6):
            col += J[r, i] * J[r, i]
        norms *= np.sqrt(col)
    if norms > 0.0:
        copy_system(J, err, Jw, ew)
        ratio = abs(lu_solve_into(Jw, ew, dq)) / norms
    pos = np.sqrt(err[0] ** 2 + err[1] ** 2 + err[2] ** 2)
    rot = np.sqrt(err[3] ** 2 + err[4] ** 2 + err[5] ** 2)
    return pos, rot, ratio


@njit(cache=True)
def _half_angle_from_ratio(num: float, den_low: float, den_high: float) -> float:
    """Angle p with tan(p/2) = num/den_low (or den_high/num), stable for any size of tan."""
    if den_low >= den_high:
        return float(2.0 * np.arctan2(num, den_low))
    return float(2.0 * np.arctan2(den_high, num))


@njit(cache=True)
def _loop_constants(
    C: FloatArray, T: FloatArray, forward: bool, start: int
) -> tuple[FloatArray, NDArray[np.int64], float]:
    """The loop ``Z(p0) K0 ... Z(p5) K5 = I`` of one split: constants, joint order, angle sign."""
    K = np.empty((6, 4, 4))
    order = np.empty(6, dtype=np.int64)
    Tinv = _rigid_inv(T)
    if forward:
        for i in range(6):
            j = (start + i) % 6
            order[i] = j
            copy_into(_mm(_mm(C[6], Tinv), C[0]) if j == 5 else C[j + 1], K[i])
        return K, order, 1.0
    for i in range(6):
        j = (start - i) % 6
        order[i] = j
        copy_into(
            _mm(_mm(_rigid_inv(C[0]), T), _rigid_inv(C[6])) if j == 0 else _rigid_inv(C[j]), K[i]
        )
    return K, order, -1.0


@njit(cache=True)
def _solve_split(
    K: FloatArray,
    P: FloatArray,
    deltas: FloatArray,
    grid: FloatArray,
    basis_inv: FloatArray,
    half2: FloatArray,
    det_phi: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    scan: FloatArray,
    phis: FloatArray,
    doubles: NDArray[np.bool_],
) -> int:
    """Candidate loop angles ``phis[k, 0..5]`` of one split; -1 if the split is degenerate."""
    Kinv5 = _rigid_inv(K[5])
    lE = np.ascontiguousarray(Kinv5[:3, 2])
    pE = np.ascontiguousarray(Kinv5[:3, 3])
    R = np.empty((14, 9))
    _rhs_coefficients(_rigid_inv(K[0]), lE, pE, grid, basis_inv, np.empty((3, 3, 14)), R)
    Q = np.empty((14, 8))
    for r in range(14):
        for c in range(8):
            Q[r, c] = R[r, c + 1]
    Vh, beta, Rq = _householder(Q)
    dmin = np.inf
    dmax = 0.0
    for k in range(8):
        dmin = min(dmin, abs(Rq[k, k]))
        dmax = max(dmax, abs(Rq[k, k]))
    if dmin < 1e-9 * dmax:
        return -1  # the eight products of p0, p1 cannot be eliminated: degenerate split
    Pm = P.copy()
    for q in range(14):
        Pm[0, q, 0] -= R[q, 0]
    N = np.zeros((6, 14))  # rows span the left null space: N @ Q = 0
    for j in range(6):
        N[j, 8 + j] = 1.0
        _reflect(Vh, beta, N[j], False)
    # Sig[h] = N @ Pm[h] @ half2 (monomials x3^i x4^j, i, j in 0..2)
    Mh = np.zeros((3, 12, 12))
    NP = np.empty((6, 9))
    for h in range(3):
        for r in range(6):
            for m in range(9):
                acc = 0.0
                for q in range(14):
                    acc += N[r, q] * Pm[h, q, m]
                NP[r, m] = acc
        for r in range(6):
            for m in range(9):
                acc = 0.0
                for k in range(9):
                    acc += NP[r, k] * half2[k, m]
                i = m // 3
                j = m % 3
                Mh[h, r, i * 3 + j] = acc
                Mh[h, r + 6, (i + 1) * 3 + j] = acc
    # Row scaling (does not move roots).
    for r in range(12):
        sq = 0.0
        for h in range(3):
            for c in range(12):
                sq += Mh[h, r, c] * Mh[h, r, c]
        if sq == 0.0:
            return -1
        sq = 1.0 / np.sqrt(sq)
        for h in range(3):
            for c in range(12):
                Mh[h, r, c] *= sq
    ndet = det_phi.shape[0]
    dets = np.empty(ndet)
    biggest = 0.0
    work = np.empty((12, 12))
    for n in range(ndet):
        _pencil_at(Mh, det_phi[n], work)
        dets[n] = _det_lu(work)
        if abs(dets[n]) > biggest:
            biggest = abs(dets[n])
    if biggest < 1e-24:  # identically zero (rounding leaves ~1e-33; regular splits >~1e-15)
        return -1  # determinant vanishes identically: degenerate split
    a = np.zeros(9)
    b = np.zeros(9)
    for n in range(ndet):
        c1, s1 = np.cos(det_phi[n]), np.sin(det_phi[n])
        ck, sk = 1.0, 0.0  # cos, sin of k * phi_n
        for k in range(9):
            a[k] += dets[n] * ck
            b[k] += dets[n] * sk
            ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
    for k in range(9):
        f = 1.0 / ndet if k == 0 else 2.0 / ndet
        a[k] *= f
        b[k] *= f
    roots = np.empty(phis.shape[0])
    count = trig_roots(a, b, scan_cos, scan_sin, scan, roots, doubles)
    if count < 0:
        return -1
    v45 = np.empty(9)
    w = np.empty(12)
    cols = np.empty(12, dtype=np.int64)
    y = np.empty(12)
    rhs = np.empty(14)
    v = np.empty(8)
    M = np.empty((4, 4))
    Mb = np.empty((4, 4))
    for c in range(count):
        p2 = roots[c]
        _pencil_at(Mh, p2, work)
        _null_vector(work, cols, y, w)
        num = 0.0
        dlo = 0.0
        dhi = 0.0
        for i in range(3):
            for j in range(3):
                num += w[i * 3 + j] * w[(i + 1) * 3 + j]
                dlo += w[i * 3 + j] ** 2
                dhi += w[(i + 1) * 3 + j] ** 2
        p3 = _half_angle_from_ratio(num, dlo, dhi)
        num = 0.0
        dlo = 0.0
        dhi = 0.0
        for i in range(4):
            for j in range(2):
                num += w[i * 3 + j] * w[i * 3 + j + 1]
                dlo += w[i * 3 + j] ** 2
                dhi += w[i * 3 + j + 1] ** 2
        p4 = _half_angle_from_ratio(num, dlo, dhi)
        b2 = (1.0, np.cos(p2), np.sin(p2))
        b3 = (1.0, np.cos(p3), np.sin(p3))
        b4 = (1.0, np.cos(p4), np.sin(p4))
        for i in range(3):
            for j in range(3):
                v45[i * 3 + j] = b3[i] * b4[j]
        for q in range(14):
            acc = 0.0
            for h in range(3):
                row = 0.0
                for m in range(9):
                    row += Pm[h, q, m] * v45[m]
                acc += b2[h] * row
            rhs[q] = acc
        # Least-squares products of p0, p1 (index h0 * 3 + h1 - 1): R v = (H^T rhs)[:8].
        _reflect(Vh, beta, rhs, True)
        for k in range(7, -1, -1):
            acc = rhs[k]
            for j in range(k + 1, 8):
                acc -= Rq[k, j] * v[j]
            v[k] = acc / Rq[k, k]
        phis[c, 0] = np.arctan2(v[5], v[2])
        phis[c, 1] = np.arctan2(v[1], v[0])
        phis[c, 2] = p2 + deltas[0]
        phis[c, 3] = p3 + deltas[1]
        phis[c, 4] = p4 + deltas[2]
        # The loop closes with Z(p5) = (Z(p0) K0 ... Z(p4) K4)^-1 K5^-1: its first column.
        M[:, :] = 0.0
        for i in range(4):
            M[i, i] = 1.0
        for i in range(5):
            cz, sz = np.cos(phis[c, i]), np.sin(phis[c, i])
            for r in range(3):
                m0 = M[r, 0]
                m1 = M[r, 1]
                M[r, 0] = m0 * cz + m1 * sz
                M[r, 1] = -m0 * sz + m1 * cz
            _affine_mul(M, K[i], Mb)
            copy_into(Mb, M)
        z0 = M[0, 0] * K[5, 0, 0] + M[1, 0] * K[5, 0, 1] + M[2, 0] * K[5, 0, 2]
        z1 = M[0, 1] * K[5, 0, 0] + M[1, 1] * K[5, 0, 1] + M[2, 1] * K[5, 0, 2]
        phis[c, 5] = np.arctan2(z1, z0)
    return count


@njit(cache=True)
def _solve_pose(
    C: FloatArray,
    P_cached: FloatArray,
    cached: NDArray[np.bool_],
    T: FloatArray,
    deltas: FloatArray,
    splits: NDArray[np.int64],
    grid: FloatArray,
    basis_inv: FloatArray,
    half2: FloatArray,
    det_phi: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    scan: FloatArray,
    newton_iterations: int,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
) -> tuple[int, int]:
    """Every solution of one pose ``T`` (lengths scaled); returns (count, split index or -1).

    ``splits[k] = (forward, start)``; ``P_cached[k]`` is the per-arm left side of split ``k``
    where ``cached[k]`` (its left side does not involve the pose).
    Flags per solution: bit 0 near-double root, bit 1 near-singular Jacobian.
    """
    split_out = -1
    kept = 0
    tries = 0
    phis = np.zeros((_CAP, 6))
    doubles = np.zeros(_CAP, dtype=np.bool_)
    q = np.empty(6)
    guess = np.empty(6)
    scratch = np.empty((3, 6, 6))
    for s in range(splits.shape[0]):
        forward = splits[s, 0] == 1
        K, order, sign = _loop_constants(C, T, forward, splits[s, 1])
        if cached[s]:
            P = P_cached[s]
        else:
            D = np.empty((4, 4, 4))
            for i in range(4):
                copy_into(K[i + 1], D[i])
            P = lhs_coefficients(D, deltas, grid, basis_inv)
        count = _solve_split(
            K,
            P,
            deltas,
            grid,
            basis_inv,
            half2,
            det_phi,
            scan_cos,
            scan_sin,
            scan,
            phis,
            doubles,
        )
        if count < 0:
            continue
        if split_out < 0:
            split_out = s
        tries += 1
        suspicious = False
        for c in range(count):
            for i in range(6):
                guess[order[i]] = sign * phis[c, i]
            for i in range(6):
                q[i] = guess[i]
            pos, rot, ratio = _refine(C, T, q, newton_iterations, guess, False, scratch)
            if not (pos <= accept and rot <= accept):
                suspicious = True
                continue
            flag = (1 if doubles[c] else 0) | (2 if ratio < 1e-6 else 0)
            before = kept
            kept, dup = keep_solution(
                q, _ALL_REVOLUTE, pos, rot, flag, out_q, out_res, out_flags, kept
            )
            if dup < 0 and not doubles[c]:
                continue
            if tries > 1 and dup >= 0 and before > 0:
                continue  # a later split re-finding a known solution is expected
            suspicious = True
            # Two candidates met (or a near-double root): look for the partner by deflation.
            known = out_q[dup if dup >= 0 else kept - 1].copy()
            for i in range(6):
                q[i] = guess[i]
            pos, rot, ratio = _refine(C, T, q, 4 * newton_iterations, known, True, scratch)
            if pos <= accept and rot <= accept:
                pos, rot, ratio = _refine(C, T, q, newton_iterations, known, False, scratch)
                if pos <= accept and rot <= accept:
                    kept, dup2 = keep_solution(
                        q,
                        _ALL_REVOLUTE,
                        pos,
                        rot,
                        1 | (2 if ratio < 1e-6 else 0),
                        out_q,
                        out_res,
                        out_flags,
                        kept,
                    )
                    if dup2 < 0:
                        out_flags[dup if dup >= 0 else kept - 2] |= 1
        # A general 6R has an even number of real solutions unless one is double: an odd count,
        # a candidate that failed to converge or candidates that met send us to the next split.
        if not suspicious and kept % 2 == 0:
            break
        if tries >= 3:
            break
    sort_solutions(out_q, out_res, out_flags, kept)
    return kept, split_out


@njit(cache=True)
def _solve_serial(
    C: FloatArray,
    P_cached: FloatArray,
    cached: NDArray[np.bool_],
    Ts: FloatArray,
    deltas: FloatArray,
    splits: NDArray[np.int64],
    grid: FloatArray,
    basis_inv: FloatArray,
    half2: FloatArray,
    det_phi: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    scan: FloatArray,
    newton_iterations: int,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
    out_split: NDArray[np.int64],
) -> None:
    """Solve the poses one after another (small batches: no thread start-up)."""
    for n in range(Ts.shape[0]):
        out_count[n], out_split[n] = _solve_pose(
            C,
            P_cached,
            cached,
            Ts[n],
            deltas,
            splits,
            grid,
            basis_inv,
            half2,
            det_phi,
            scan_cos,
            scan_sin,
            scan,
            newton_iterations,
            accept,
            out_q[n],
            out_res[n],
            out_flags[n],
        )


@njit(cache=True, parallel=True)
def _solve_parallel(
    C: FloatArray,
    P_cached: FloatArray,
    cached: NDArray[np.bool_],
    Ts: FloatArray,
    deltas: FloatArray,
    splits: NDArray[np.int64],
    grid: FloatArray,
    basis_inv: FloatArray,
    half2: FloatArray,
    det_phi: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    scan: FloatArray,
    newton_iterations: int,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
    out_split: NDArray[np.int64],
) -> None:
    """Solve the poses on all cores."""
    for n in prange(Ts.shape[0]):
        out_count[n], out_split[n] = _solve_pose(
            C,
            P_cached,
            cached,
            Ts[n],
            deltas,
            splits,
            grid,
            basis_inv,
            half2,
            det_phi,
            scan_cos,
            scan_sin,
            scan,
            newton_iterations,
            accept,
            out_q[n],
            out_res[n],
            out_flags[n],
        )


#: The twelve loop splits, (forward, start joint); the first is the classic Raghavan-Roth one.
SPLITS = np.array(
    [
        (1, 0),
        (0, 5),
        (1, 1),
        (1, 2),
        (1, 3),
        (1, 4),
        (1, 5),
        (0, 0),
        (0, 1),
        (0, 2),
        (0, 3),
        (0, 4),
    ],
    dtype=np.int64,
)


class General6RSolver(CompiledSolver):
    """All IK solutions of one 6R arm; construct once per arm (about 1 ms), then solve poses.

    >>> solver = General6RSolver(arm)            # doctest: +SKIP
    >>> result = solver.solve(T_target)          # IKResult, every real solution
    >>> batch = solver.solve_batch(Ts)           # IKBatch: padded arrays; batch[i] is an IKResult
    """

    def __init__(self, arm: SerialArm, *, newton_iterations: int = 12, accept: float = 1e-8):
        if arm.n_joints != 6 or any(j.kind is not JointKind.REVOLUTE for j in arm.joints):
            raise InvalidInputError(
                f"model {arm.name!r}: the general solver needs six revolute joints "
                f"(got {arm.n_joints} joints: "
                f"{''.join('R' if j.kind is JointKind.REVOLUTE else 'P' for j in arm.joints)})"
            )
        self.arm = arm
        C = z_axis_chain(arm)
        #: Length scale (model unit) that makes the arm's translations of order one.
        self.length_scale = chain_length_scale(C)
        C[:, :3, 3] /= self.length_scale
        self._C = np.ascontiguousarray(C)
        self._deltas = DEFAULT_DELTAS.copy()
        # Left sides that do not involve the pose are measured once per arm: a split's loop
        # holds the pose next to joint 6 (forward) or joint 1 (reversed); it must not sit
        # between the three left-side joints.
        self._P_cached = np.zeros((len(SPLITS), 3, 14, 9))
        self._cached = np.zeros(len(SPLITS), dtype=np.bool_)
        for k, (forward, start) in enumerate(SPLITS):
            K, order, _ = _loop_constants(self._C, np.eye(4), bool(forward), int(start))
            pose_slot = int(np.flatnonzero(order == (5 if forward else 0))[0])
            if pose_slot in (0, 5):
                self._P_cached[k] = lhs_coefficients(
                    np.ascontiguousarray(K[1:5]), self._deltas, _GRID, _BASIS_INV
                )
                self._cached[k] = True
        self.newton_iterations = newton_iterations
        self.accept = accept

    method_names = (*(f"raghavan-roth (split {k.tolist()})" for k in SPLITS), "raghavan-roth")
    failure_reasons = (
        "no real solution: the pose is out of reach",
        "elimination degenerate in all 12 splits (a positive-dimensional solution set, "
        "e.g. aligned joint axes at this pose)",
    )

    def _run(self, T: FloatArray) -> KernelOutput:
        N = T.shape[0]
        q, res, flags, count = padded_outputs(N, _CAP)
        split = np.zeros(N, dtype=np.int64)
        kernel = _solve_parallel if threads_pay_off(N, 64) else _solve_serial
        kernel(
            self._C,
            self._P_cached,
            self._cached,
            T,
            self._deltas,
            SPLITS,
            _GRID,
            _BASIS_INV,
            _HALF2,
            _DET_PHI,
            _SCAN_COS,
            _SCAN_SIN,
            _SCAN,
            self.newton_iterations,
            self.accept,
            q,
            res,
            flags,
            count,
            split,
        )
        degenerate = split < 0
        return (
            q,
            res,
            flags,
            count,
            np.where(degenerate, len(SPLITS), split),
            degenerate.astype(np.int64),
        )
