"""Numerical kernels shared by the complete IK solvers (compiled with numba).

Small dense solves, real roots of trigonometric polynomials, the forward-kinematics error and
Jacobian of a z-axis chain, and the Newton polish every candidate solution gets.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.jit import njit
from armpath.kinematics import _affine_mul, copy_into

FloatArray = NDArray[np.float64]


def scan_tables(n_points: int, n_harmonics: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A root-scan grid of ``n_points`` angles on [0, 2 pi) and cos/sin of harmonics
    ``0..n_harmonics-1`` on it, for :func:`trig_roots`."""
    scan = np.arange(n_points) * (2.0 * np.pi / n_points)
    k = np.arange(n_harmonics)
    return (
        np.ascontiguousarray(scan, dtype=np.float64),
        np.ascontiguousarray(np.cos(np.outer(scan, k))),
        np.ascontiguousarray(np.sin(np.outer(scan, k))),
    )


@njit(cache=True)
def lu_solve_into(A: FloatArray, rhs: FloatArray, x: FloatArray) -> float:
    """Solve ``A x = rhs`` by LU with partial pivoting into ``x`` (A, rhs overwritten); returns
    det(A) (0 when singular, x then zero)."""
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
            for i in range(n):
                x[i] = 0.0
            return 0.0
        if piv != k:
            for c in range(n):
                tmp = A[k, c]
                A[k, c] = A[piv, c]
                A[piv, c] = tmp
            tmp = rhs[k]
            rhs[k] = rhs[piv]
            rhs[piv] = tmp
            det = -det
        det *= A[k, k]
        inv = 1.0 / A[k, k]
        for r in range(k + 1, n):
            f = A[r, k] * inv
            if f != 0.0:
                for c in range(k + 1, n):
                    A[r, c] -= f * A[k, c]
                rhs[r] -= f * rhs[k]
    for k in range(n - 1, -1, -1):
        acc = rhs[k]
        for c in range(k + 1, n):
            acc -= A[k, c] * x[c]
        x[k] = acc / A[k, k]
    return det


@njit(cache=True)
def _trig_eval(a: FloatArray, b: FloatArray, phi: float) -> tuple[float, float, float]:
    """Value, first and second derivative of sum_k a_k cos k phi + b_k sin k phi."""
    c1 = np.cos(phi)
    s1 = np.sin(phi)
    c = 1.0
    s = 0.0
    g = a[0]
    d1 = 0.0
    d2 = 0.0
    for k in range(1, a.shape[0]):
        c, s = c * c1 - s * s1, s * c1 + c * s1
        t = a[k] * c + b[k] * s
        g += t
        d1 += k * (b[k] * c - a[k] * s)
        d2 -= k * k * t
    return g, d1, d2


@njit(cache=True)
def _bracketed_root(
    a: FloatArray, b: FloatArray, lo: float, hi: float, glo: float, ghi: float
) -> float:
    """Root of the trigonometric polynomial in [lo, hi] where its values ``glo``, ``ghi`` differ
    in sign: safeguarded Newton from the secant point."""
    x = lo + (hi - lo) * glo / (glo - ghi)
    if not (lo < x < hi):
        x = 0.5 * (lo + hi)
    for _ in range(60):
        g, d1, _d2 = _trig_eval(a, b, x)
        if g == 0.0:
            return x
        if (g < 0.0) == (glo < 0.0):
            lo = x
            glo = g
        else:
            hi = x
        step = g / d1 if d1 != 0.0 else 0.0
        xn = x - step
        if abs(step) < 1e-12:  # quadratic convergence: this step lands at rounding level
            return xn if lo <= xn <= hi else x
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        x = xn
        if hi - lo < 1e-14:
            break
    return x


@njit(cache=True)
def _hidden_pair(dm: float, d0: float, d1: float, d2: float) -> bool:
    """Whether g' sampled at four consecutive grid points may have two roots in the middle cell.

    All four values share a sign and |g'| is smallest in the middle; a parabola through either
    three-point window then predicts how low |g'| gets. Cells are sub-sampled only when it comes
    below a quarter of the smaller end value (or crosses zero).
    """
    if not ((dm < 0.0) == (d0 < 0.0) == (d1 < 0.0) == (d2 < 0.0)):
        return False
    if not (abs(d0) <= abs(dm) and abs(d1) <= abs(d2)):
        return False
    low = min(abs(d0), abs(d1))
    for y0, y1, y2 in ((abs(dm), abs(d0), abs(d1)), (abs(d0), abs(d1), abs(d2))):
        curv = y0 - 2.0 * y1 + y2
        if curv > 0.0:
            slope = 0.5 * (y2 - y0)
            vmin = y1 - slope * slope / (2.0 * curv)
            if vmin < 0.25 * low:
                return True
    return False


@njit(cache=True)
def _scan_values(
    a: FloatArray,
    b: FloatArray,
    da: FloatArray,
    db: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    vals: FloatArray,
    der: FloatArray,
) -> float:
    """Values and derivatives (coefficients ``da``, ``db``) of a trigonometric polynomial on the
    scan grid; returns the largest |value|."""
    scale = 0.0
    for i in range(scan_cos.shape[0]):
        v = 0.0
        dv = 0.0
        for k in range(a.shape[0]):
            v += scan_cos[i, k] * a[k] + scan_sin[i, k] * b[k]
            dv += scan_cos[i, k] * da[k] + scan_sin[i, k] * db[k]
        vals[i] = v
        der[i] = dv
        scale = max(scale, abs(v))
    return scale


@njit(cache=True)
def trig_roots(
    a: FloatArray,
    b: FloatArray,
    scan_cos: FloatArray,
    scan_sin: FloatArray,
    scan: FloatArray,
    roots: FloatArray,
    doubles: NDArray[np.bool_],
) -> int:
    """Real roots in [0, 2 pi) of g = sum a_k cos k p + b_k sin k p; their count (-1 if g = 0).

    The critical points of g (sign changes of g' on the grid, refined by Newton) cut the circle
    into pieces on which g is monotone; each piece holds at most one root, bracketed exactly.
    Two roots closer than the grid step are thus still separated, and a critical point where g
    touches zero is returned once and marked as a double root.
    """
    n = scan.shape[0]
    m = a.shape[0]
    # Derivative coefficients: g' = sum (k b_k) cos + (-k a_k) sin.
    da = np.empty(m)
    db = np.empty(m)
    for k in range(m):
        da[k] = k * b[k]
        db[k] = -k * a[k]
    vals = np.empty(n)
    der = np.empty(n)
    scale = _scan_values(a, b, da, db, scan_cos, scan_sin, vals, der)
    if scale == 0.0:
        return -1
    h = 2.0 * np.pi / n
    xs = np.empty(2 * n + 1)
    gs = np.empty(2 * n + 1)
    crit = np.zeros(2 * n + 1, dtype=np.bool_)
    npts = 0
    for i in range(n):
        xs[npts] = scan[i]
        gs[npts] = vals[i]
        npts += 1
        d0 = der[i]
        d1 = der[(i + 1) % n]
        if (d0 < 0.0) != (d1 < 0.0) and d1 != 0.0 and d0 != 0.0:
            x = _bracketed_root(da, db, scan[i], scan[i] + h, d0, d1)
            g, _, _ = _trig_eval(a, b, x)
            xs[npts] = x
            gs[npts] = g
            crit[npts] = True
            npts += 1
        elif _hidden_pair(der[(i - 1) % n], d0, d1, der[(i + 2) % n]):
            # g' may cross zero twice inside this cell: sub-sample it.
            sub = 24
            hs = h / sub
            xprev = scan[i]
            dprev = d0
            for k in range(1, sub + 1):
                xk = scan[i] + k * hs
                _, dk, _ = _trig_eval(a, b, xk)
                if k == sub:
                    dk = d1
                if (dprev < 0.0) != (dk < 0.0) and dk != 0.0 and dprev != 0.0 and npts < 2 * n:
                    x = _bracketed_root(da, db, xprev, xk, dprev, dk)
                    g, _, _ = _trig_eval(a, b, x)
                    xs[npts] = x
                    gs[npts] = g
                    crit[npts] = True
                    npts += 1
                xprev = xk
                dprev = dk
    xs[npts] = 2.0 * np.pi
    gs[npts] = vals[0]
    count = 0
    cap = roots.shape[0]
    for i in range(npts):
        g0 = gs[i]
        g1 = gs[i + 1]
        if g0 == 0.0 or (crit[i] and abs(g0) <= 1e-13 * scale):
            if count < cap:
                roots[count] = xs[i]
                doubles[count] = crit[i]
                count += 1
            continue
        if (g0 < 0.0) != (g1 < 0.0) and g1 != 0.0:
            if crit[i + 1] and abs(g1) <= 1e-13 * scale:
                continue  # the double root at the next point is taken there
            if count < cap:
                roots[count] = _bracketed_root(a, b, xs[i], xs[i + 1], g0, g1)
                doubles[count] = False
                count += 1
    return count


@njit(cache=True)
def fk_error_jacobian(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    q: FloatArray,
    T: FloatArray,
    err: FloatArray,
    J: FloatArray,
) -> None:
    """Pose error ``[position; rotation vector]`` of FK(q) to ``T`` into ``err`` and the
    geometric Jacobian into ``J`` (6 x n), for the chain ``C0 Z(q1) C1 ... Z(qn) Cn``.

    Allocation-light: it is the innermost loop of every complete solver's Newton polish.
    """
    n = q.shape[0]
    A = C[0].copy()
    B = np.empty((4, 4))
    for i in range(n):
        for r in range(3):
            J[3 + r, i] = A[r, 2]  # axis, kept here until the position is known
        v = q[i]
        if prismatic[i]:
            for r in range(3):
                A[r, 3] += A[r, 2] * v
        else:
            c, sn = np.cos(v), np.sin(v)
            for r in range(3):
                a0 = A[r, 0]
                a1 = A[r, 1]
                A[r, 0] = a0 * c + a1 * sn
                A[r, 1] = -a0 * sn + a1 * c
        for r in range(3):
            J[r, i] = A[r, 3]  # joint origin, likewise
        _affine_mul(A, C[i + 1], B)
        A, B = B, A
    px, py, pz = A[0, 3], A[1, 3], A[2, 3]
    for i in range(n):
        zx, zy, zz = J[3, i], J[4, i], J[5, i]
        if prismatic[i]:
            J[0, i], J[1, i], J[2, i] = zx, zy, zz
            J[3, i] = J[4, i] = J[5, i] = 0.0
            continue
        rx, ry, rz = px - J[0, i], py - J[1, i], pz - J[2, i]
        J[0, i] = zy * rz - zz * ry
        J[1, i] = zz * rx - zx * rz
        J[2, i] = zx * ry - zy * rx
    err[0] = T[0, 3] - px
    err[1] = T[1, 3] - py
    err[2] = T[2, 3] - pz
    wx = 0.0
    wy = 0.0
    wz = 0.0
    for k in range(3):  # 0.5 * sum_k cross(R_k, Rt_k) over the columns (exact to first order)
        wx += A[1, k] * T[2, k] - A[2, k] * T[1, k]
        wy += A[2, k] * T[0, k] - A[0, k] * T[2, k]
        wz += A[0, k] * T[1, k] - A[1, k] * T[0, k]
    err[3] = 0.5 * wx
    err[4] = 0.5 * wy
    err[5] = 0.5 * wz


@njit(cache=True)
def wrap_angle(x: float) -> float:
    return (x + np.pi) % (2.0 * np.pi) - np.pi


@njit(cache=True)
def _rigid_error(T: FloatArray) -> float:
    """Largest |R R^T - I| entry of each pose (inf if not finite or the last row is wrong)."""
    worst = 0.0
    for n in range(T.shape[0]):
        for i in range(4):
            for j in range(4):
                if not np.isfinite(T[n, i, j]):
                    return np.inf
        if T[n, 3, 0] != 0.0 or T[n, 3, 1] != 0.0 or T[n, 3, 2] != 0.0 or T[n, 3, 3] != 1.0:
            return np.inf
        for i in range(3):
            for j in range(3):
                dot = T[n, i, 0] * T[n, j, 0] + T[n, i, 1] * T[n, j, 1] + T[n, i, 2] * T[n, j, 2]
                worst = max(worst, abs(dot - (1.0 if i == j else 0.0)))
    return worst


def prepare_targets(Ts: FloatArray, length_scale: float) -> FloatArray:
    """Validated copies of target poses ``(N, 4, 4)`` with lengths divided by ``length_scale``.

    Rotations within 1e-6 of orthonormal (poses printed to a few digits) are replaced by the
    nearest rotation; anything else is rejected with :class:`InvalidInputError`.
    """
    T = np.array(Ts, dtype=np.float64).reshape(-1, 4, 4) if np.size(Ts) % 16 == 0 else None
    if T is None or T.shape[0] == 0:
        raise InvalidInputError("target poses must be 4x4 matrices")
    err = _rigid_error(T)
    if not err <= 1e-6:
        raise InvalidInputError(
            "target poses must be finite rigid transforms (orthonormal rotation, last row 0 0 0 1)"
        )
    if err > 1e-13:
        U, _, Vt = np.linalg.svd(T[:, :3, :3])
        T[:, :3, :3] = U @ Vt
    T[:, :3, 3] /= length_scale
    return T


@njit(cache=True)
def copy_system(J: FloatArray, err: FloatArray, Jw: FloatArray, ew: FloatArray) -> None:
    """``Jw = J``, ``ew = err`` (6 x 6 and 6) element by element
    (:func:`~armpath.kinematics.copy_into`: numba compiles whole-slice assignment through its
    general broadcasting code, seconds per kernel that uses it)."""
    copy_into(J, Jw)
    for i in range(6):
        ew[i] = err[i]


@njit(cache=True)
def newton_polish(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    T: FloatArray,
    q: FloatArray,
    steps: int,
    scratch: FloatArray,
) -> tuple[float, float, float]:
    """Newton steps on the full pose for a closed-form candidate ``q`` (updated in place).

    Returns (position error, rotation error, Jacobian ratio |det J| / prod |J_i|, small near a
    singularity). ``scratch`` is a (4, 6, 6) work array, so nothing is allocated.
    """
    J = scratch[0]
    Jw = scratch[1]
    err = scratch[2, 0]
    ew = scratch[2, 1]
    dq = scratch[2, 2]
    fk_error_jacobian(C, prismatic, q, T, err, J)
    for _ in range(steps):
        size2 = 0.0
        for i in range(6):
            size2 += err[i] * err[i]
        if size2 < 1e-26:
            break  # closed-form candidates are usually exact already
        copy_system(J, err, Jw, ew)
        if lu_solve_into(Jw, ew, dq) == 0.0:
            break
        for i in range(6):
            q[i] += dq[i]
        fk_error_jacobian(C, prismatic, q, T, err, J)
    norms = 1.0
    for i in range(6):
        col2 = 0.0
        for r in range(6):
            col2 += J[r, i] * J[r, i]
        norms *= max(np.sqrt(col2), 1e-300)
    copy_system(J, err, Jw, ew)
    ratio = abs(lu_solve_into(Jw, ew, dq)) / norms
    pos = np.sqrt(err[0] ** 2 + err[1] ** 2 + err[2] ** 2)
    rot = np.sqrt(err[3] ** 2 + err[4] ** 2 + err[5] ** 2)
    return pos, rot, ratio


@njit(cache=True)
def sort_solutions(q: FloatArray, res: FloatArray, flags: NDArray[np.int64], count: int) -> None:
    """Sort the first ``count`` rows of ``q`` lexicographically (insertion sort; at most a few
    dozen rows), carrying their residuals and flags along."""
    for i in range(1, count):
        j = i
        while j > 0:
            k = 0
            while k < q.shape[1] - 1 and q[j - 1, k] == q[j, k]:
                k += 1
            if q[j - 1, k] <= q[j, k]:
                break
            for c in range(q.shape[1]):
                q[j - 1, c], q[j, c] = q[j, c], q[j - 1, c]
            for c in range(res.shape[1]):
                res[j - 1, c], res[j, c] = res[j, c], res[j - 1, c]
            flags[j - 1], flags[j] = flags[j], flags[j - 1]
            j -= 1


@njit(cache=True)
def keep_solution(
    q: FloatArray,
    prismatic: NDArray[np.bool_],
    pos: float,
    rot: float,
    flag: int,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    kept: int,
) -> tuple[int, int]:
    """Store a verified solution (revolute angles wrapped in place) unless it repeats a stored
    one to 1e-6, whose flags then gain ``flag``; returns (new count, index repeated or -1)."""
    for i in range(q.shape[0]):
        if not prismatic[i]:
            q[i] = wrap_angle(q[i])
    for m in range(kept):
        same = True
        for i in range(q.shape[0]):
            diff = out_q[m, i] - q[i]
            if not prismatic[i]:
                diff = wrap_angle(diff)
            if abs(diff) > 1e-6:
                same = False
                break
        if same:
            out_flags[m] |= flag
            return kept, m
    if kept < out_q.shape[0]:
        for i in range(q.shape[0]):
            out_q[kept, i] = q[i]
        out_res[kept, 0] = pos
        out_res[kept, 1] = rot
        out_flags[kept] = flag
        kept += 1
    return kept, -1
