"""Compiled (numba) kernels: exact smallest signed distance along line segments.

Every kernel takes flat arrays of segments ``p0 (K, 3)``, ``p1 (K, 3)`` and returns ``(K,)``: the
smallest signed distance of any point of each segment to one solid (negative inside).

Solid of revolution (profile polygon in the ``(r, z)`` half-plane, revolved about an axis)
----------------------------------------------------------------------------------------
Along a segment ``x(t) = p0 + t (p1 - p0)``, ``z(t)`` is linear and ``r(t) = sqrt(q(t))`` with
``q`` quadratic. The unsigned distance to the surface is the smallest distance to a profile
*feature*: an edge (a cone, cylinder or annulus in 3-D) or a vertex (a circle). Its minimum over
``t`` is therefore the smallest of the features' minima, and each of those lies at

* an end of the segment, or where the segment meets the axis (``q`` smallest: ``r`` has a kink);
* for an edge line ``f(t) = n_r (r - r_a) + n_z (z - z_a)``: a stationary point of ``f``
  (``n_r^2 q'^2 = 4 n_z^2 z'^2 q``) or a zero of ``f`` (``n_r^2 q = L(t)^2``) -- two quadratics;
  points whose foot lies beyond the edge's ends are covered by the vertices;
* for a vertex circle ``(R, Z)``: a stationary point of ``(r - R)^2 + (z - Z)^2``, a root of the
  quartic ``(q' + 2 (z - Z) z')^2 q = R^2 q'^2``.

All real roots in ``[0, 1]`` of these polynomials are found by isolating them between the roots
of the derivative (recursively down to a closed-form quadratic) and bisecting; stationary points
of the polynomials are candidates too, so near-double roots that rounding turns complex are not
lost. The exact 2-D signed distance is evaluated at every candidate and the smallest kept. When the
segment stays outside the solid this is the exact minimum (to rounding); when it enters the solid
the value is negative and attained by the segment: every stretch between candidates that lies
inside is searched for its deepest point (the deepest point can lie where two features are
equally near, which no candidate marks), so a segment that passes through a wall is never
reported as merely touching it.

Convex solids (boxes) use a golden-section search of their convex signed distance along the
segment, to :data:`GOLDEN_ITERATIONS` steps (parameter interval below 1e-14 of the segment).
"""

from __future__ import annotations

import math

import numpy as np

from armpath.jit import njit

#: Golden-section steps for convex solids: 0.618^72 < 1e-14 of the segment length.
GOLDEN_ITERATIONS = 72
_BISECTIONS = 60
#: Golden-section steps searching a stretch of a segment inside a solid for its deepest point.
_INSIDE_GOLDEN = 40
#: Extra points along a segment whose distance bounds the minimum from above (feature pruning).
_PRUNE_SAMPLES = 2
#: Below this distance (length unit) a segment counts as touching the surface
#: (equals :data:`armpath.geometry.primitives.TOUCHING`).
_TOUCH = 1e-9
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


@njit(cache=True, fastmath=False)
def _polygon_sdf(r: float, z: float, verts: np.ndarray, boundary: np.ndarray) -> float:
    """Signed distance of ``(r, z)`` to a closed polygon; only ``boundary`` edges count."""
    n = verts.shape[0]
    best = np.inf
    inside = False
    for i in range(n):
        ar, az = verts[i, 0], verts[i, 1]
        j = i + 1 if i + 1 < n else 0
        br, bz = verts[j, 0], verts[j, 1]
        er, ez = br - ar, bz - az
        if (az > z) != (bz > z) and r < ar + (z - az) * er / ez:
            inside = not inside
        if boundary[i]:
            wr, wz = r - ar, z - az
            ll = er * er + ez * ez
            s = (wr * er + wz * ez) / ll if ll > 0.0 else 0.0
            s = min(max(s, 0.0), 1.0)
            dr, dz = wr - s * er, wz - s * ez
            d2 = dr * dr + dz * dz
            if d2 < best:
                best = d2
    d = math.sqrt(best)
    return -d if inside else d


@njit(cache=True)
def _newton_bracket(
    c0: float, c1: float, c2: float, c3: float, c4: float, lo: float, hi: float
) -> float:
    """Root of the quartic ``c`` in ``[lo, hi]`` where it is monotone and changes sign.

    Safeguarded Newton: a Newton step that leaves the bracket is replaced by bisection.
    """
    flo = c0 + lo * (c1 + lo * (c2 + lo * (c3 + lo * c4)))
    t = 0.5 * (lo + hi)
    for _ in range(_BISECTIONS):
        f = c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)))
        if f == 0.0:
            return t
        if (f < 0.0) == (flo < 0.0):
            lo = t
        else:
            hi = t
        df = c1 + t * (2.0 * c2 + t * (3.0 * c3 + t * 4.0 * c4))
        step_ok = False
        if df != 0.0:
            tn = t - f / df
            if lo < tn < hi:
                step_ok = True
                if abs(tn - t) < 1e-15:
                    return tn
                t = tn
        if not step_ok:
            t = 0.5 * (lo + hi)
        if hi - lo < 1e-15:
            return t
    return t


@njit(cache=True)
def _quartic_unit_roots(
    c0: float, c1: float, c2: float, c3: float, c4: float, out: np.ndarray, n: int
) -> int:
    """Append the real roots in ``[0, 1]`` of ``c0 + c1 t + ... + c4 t^4`` and its stationary
    points there to ``out[n:]``; return the new count.

    Degree drops when leading coefficients vanish relative to the others. Roots are isolated
    between consecutive stationary points (the cubic derivative's roots, themselves isolated by
    the quadratic second derivative's closed-form roots), so every sign change is bracketed.
    """
    scale = max(abs(c0), abs(c1), abs(c2), abs(c3), abs(c4))
    if scale == 0.0:
        return n
    eps = 1e-13 * scale
    if abs(c4) <= eps:
        c4 = 0.0
        if abs(c3) <= eps:
            c3 = 0.0
            if abs(c2) <= eps:
                c2 = 0.0
                if abs(c1) <= eps:
                    return n
                t = -c0 / c1
                if 0.0 <= t <= 1.0:
                    out[n] = t
                    n += 1
                return n
    # stationary points of the cubic derivative d(t) = c1 + 2c2 t + 3c3 t^2 + 4c4 t^3:
    # roots of d'(t) = 2c2 + 6c3 t + 12c4 t^2 (closed form)
    s_lo, s_hi = 2.0, 2.0  # sentinels outside [0, 1]
    a2, a1, a0 = 12.0 * c4, 6.0 * c3, 2.0 * c2
    if a2 != 0.0:
        disc = a1 * a1 - 4.0 * a2 * a0
        if disc >= 0.0:
            sq = math.sqrt(disc)
            qq = -0.5 * (a1 + sq) if a1 >= 0.0 else -0.5 * (a1 - sq)
            r1 = qq / a2
            r2 = a0 / qq if qq != 0.0 else r1
            s_lo, s_hi = min(r1, r2), max(r1, r2)
        else:
            s_lo = -a1 / (2.0 * a2)  # complex pair: keep the real part as a breakpoint
    elif a1 != 0.0:
        s_lo = -a0 / a1
    # roots of d between its own breakpoints 0 <= s_lo <= s_hi <= 1 (d monotone on each piece)
    e1, e2 = 1.0, 1.0
    if 0.0 < s_lo < 1.0:
        e1 = s_lo
        if s_lo < s_hi < 1.0:
            e2 = s_hi
    elif 0.0 < s_hi < 1.0:
        e1 = s_hi
    crit_buf0, crit_buf1, crit_buf2 = 2.0, 2.0, 2.0
    n_crit = 0
    for piece in range(3):
        lo = 0.0 if piece == 0 else (e1 if piece == 1 else e2)
        hi = e1 if piece == 0 else (e2 if piece == 1 else 1.0)
        if not (lo < hi):
            continue
        dlo = c1 + lo * (2.0 * c2 + lo * (3.0 * c3 + lo * 4.0 * c4))
        dhi = c1 + hi * (2.0 * c2 + hi * (3.0 * c3 + hi * 4.0 * c4))
        if dlo == 0.0:
            root = lo
        elif (dlo < 0.0) != (dhi < 0.0):
            root = _newton_bracket(c1, 2.0 * c2, 3.0 * c3, 4.0 * c4, 0.0, lo, hi)
        else:
            continue
        if n_crit == 0:
            crit_buf0 = root
        elif n_crit == 1:
            crit_buf1 = root
        else:
            crit_buf2 = root
        n_crit += 1
    # stationary points are candidates; they also bracket the roots of c
    prev = 0.0
    for piece in range(n_crit + 1):
        nxt = 1.0
        if piece < n_crit:
            nxt = crit_buf0 if piece == 0 else (crit_buf1 if piece == 1 else crit_buf2)
            out[n] = nxt
            n += 1
        lo, hi = prev, nxt
        prev = nxt
        if not (lo <= hi):
            continue
        flo = c0 + lo * (c1 + lo * (c2 + lo * (c3 + lo * c4)))
        fhi = c0 + hi * (c1 + hi * (c2 + hi * (c3 + hi * c4)))
        if flo == 0.0:
            out[n] = lo
            n += 1
        elif (flo < 0.0) != (fhi < 0.0):
            out[n] = _newton_bracket(c0, c1, c2, c3, c4, lo, hi)
            n += 1
    return n


@njit(cache=True)
def _quadratic_unit_roots(c0: float, c1: float, c2: float, out: np.ndarray, n: int) -> int:
    """Append the real roots in ``[0, 1]`` of ``c0 + c1 t + c2 t^2`` and its stationary point
    (the real part of a complex pair, so near-double roots are not lost) to ``out[n:]``."""
    scale = max(abs(c0), abs(c1), abs(c2))
    if scale == 0.0:
        return n
    if abs(c2) <= 1e-13 * scale:
        if abs(c1) > 1e-13 * scale:
            t = -c0 / c1
            if 0.0 <= t <= 1.0:
                out[n] = t
                n += 1
        return n
    t = -c1 / (2.0 * c2)
    if 0.0 <= t <= 1.0:
        out[n] = t
        n += 1
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc >= 0.0:
        sq = math.sqrt(disc)
        qq = -0.5 * (c1 + sq) if c1 >= 0.0 else -0.5 * (c1 - sq)
        t1 = qq / c2
        if 0.0 <= t1 <= 1.0:
            out[n] = t1
            n += 1
        if qq != 0.0:
            t2 = c0 / qq
            if 0.0 <= t2 <= 1.0:
                out[n] = t2
                n += 1
    return n


@njit(cache=True)
def _box_point_2d(rmin: float, rmax: float, zmin: float, zmax: float, r: float, z: float) -> float:
    dr = max(rmin - r, 0.0, r - rmax)
    dz = max(zmin - z, 0.0, z - zmax)
    return math.sqrt(dr * dr + dz * dz)


@njit(cache=True)
def _feature_distance(
    q0: float, q1: float, q2: float, z0: float, zd: float, t: float,
    ar: float, az: float, er: float, ez: float, is_edge: bool,
) -> float:  # fmt: skip
    """Distance at ``t`` to one profile feature: the edge from ``(ar, az)`` along ``(er, ez)``
    (inf when the foot falls beyond its ends: a vertex covers that) or the vertex ``(ar, az)``."""
    qt = q0 + t * (q1 + t * q2)
    wr = math.sqrt(max(qt, 0.0)) - ar
    wz = z0 + t * zd - az
    if not is_edge:
        return math.sqrt(wr * wr + wz * wz)
    ll = er * er + ez * ez
    s = wr * er + wz * ez
    if s < 0.0 or s > ll:
        return np.inf
    return abs(wr * ez - wz * er) / math.sqrt(ll)


@njit(cache=True)
def segment_revolution(
    p: np.ndarray,
    k: int,
    origin: np.ndarray,
    axis: np.ndarray,
    verts: np.ndarray,
    boundary: np.ndarray,
    cands: np.ndarray,
) -> float:
    """Smallest signed distance of segment ``p[k, 0:3] -> p[k, 3:6]`` to a solid of revolution.

    Each candidate is scored by the distance to the feature that produced it (cheap); only a
    segment that touches, crosses or lies inside the surface has the full signed distance
    evaluated at every candidate.
    """
    ax0, ax1, ax2 = axis[0], axis[1], axis[2]
    a0, a1, a2 = p[k, 0] - origin[0], p[k, 1] - origin[1], p[k, 2] - origin[2]
    d0, d1, d2 = p[k, 3] - p[k, 0], p[k, 4] - p[k, 1], p[k, 5] - p[k, 2]
    z0 = a0 * ax0 + a1 * ax1 + a2 * ax2
    zd = d0 * ax0 + d1 * ax1 + d2 * ax2
    ap0, ap1, ap2 = a0 - z0 * ax0, a1 - z0 * ax1, a2 - z0 * ax2
    dp0, dp1, dp2 = d0 - zd * ax0, d1 - zd * ax1, d2 - zd * ax2
    q0 = ap0 * ap0 + ap1 * ap1 + ap2 * ap2
    q1 = 2.0 * (ap0 * dp0 + ap1 * dp1 + ap2 * dp2)
    q2 = dp0 * dp0 + dp1 * dp1 + dp2 * dp2
    qe = q0 + q1 + q2
    cands[0] = 0.0
    cands[1] = 1.0
    n = 2
    qmin = min(q0, qe)
    if q2 > 0.0:
        t = -q1 / (2.0 * q2)
        if 0.0 < t < 1.0:
            cands[n] = t
            n += 1
            qmin = min(qmin, q0 + t * (q1 + t * q2))
    # (r, z) bounding box of the segment, and an upper bound of the smallest distance
    rmin = math.sqrt(max(qmin, 0.0))
    rmax = math.sqrt(max(q0, qe, 0.0))
    zmin, zmax = min(z0, z0 + zd), max(z0, z0 + zd)
    sdf_start = _polygon_sdf(math.sqrt(max(q0, 0.0)), z0, verts, boundary)
    best_abs = abs(sdf_start)
    for i in range(1, n + _PRUNE_SAMPLES):
        t = cands[i] if i < n else (i - n + 0.5) / _PRUNE_SAMPLES
        qt = q0 + t * (q1 + t * q2)
        s = _polygon_sdf(math.sqrt(max(qt, 0.0)), z0 + t * zd, verts, boundary)
        best_abs = min(best_abs, abs(s))
    nv = verts.shape[0]
    n_base = n
    # features farther than the best distance so far are skipped; a segment that touches or
    # enters the solid is swept again with every feature, so that every crossing is a
    # candidate and the stretches inside the solid lie between candidates
    for sweep in range(2):
        if sweep == 1:
            if best_abs > _TOUCH and sdf_start > 0.0:
                break
            n = n_base
        for i in range(nv):
            reach = best_abs if sweep == 0 else np.inf
            j = i + 1 if i + 1 < nv else 0
            ar, az = verts[i, 0], verts[i, 1]
            br, bz = verts[j, 0], verts[j, 1]
            er, ez = br - ar, bz - az
            if boundary[i]:
                # lower bound: distance between the segment's box and the edge's box
                dr = max(rmin - max(ar, br), 0.0, min(ar, br) - rmax)
                dz = max(zmin - max(az, bz), 0.0, min(az, bz) - zmax)
                ln = math.sqrt(er * er + ez * ez)
                if dr * dr + dz * dz < reach * reach and ln > 0.0:
                    nr, nz = ez / ln, -er / ln
                    n_before = n
                    # zeros of f: nr^2 q - L^2 with L = nz (z - az) - nr ar
                    l0 = nz * (z0 - az) - nr * ar
                    l1 = nz * zd
                    n = _quadratic_unit_roots(
                        nr * nr * q0 - l0 * l0,
                        nr * nr * q1 - 2.0 * l0 * l1,
                        nr * nr * q2 - l1 * l1,
                        cands,
                        n,
                    )
                    # stationary points of f: nr^2 (q1 + 2 q2 t)^2 - 4 nz^2 zd^2 q
                    kk = 4.0 * nz * nz * zd * zd
                    n = _quadratic_unit_roots(
                        nr * nr * q1 * q1 - kk * q0,
                        4.0 * nr * nr * q1 * q2 - kk * q1,
                        4.0 * nr * nr * q2 * q2 - kk * q2,
                        cands,
                        n,
                    )
                    for c in range(n_before, n):
                        dist = _feature_distance(q0, q1, q2, z0, zd, cands[c], ar, az, er, ez, True)
                        best_abs = min(best_abs, dist)
            # vertex circle (R, Z) = (ar, az): (u0 + u1 t)^2 q - R^2 (q1 + 2 q2 t)^2
            if _box_point_2d(rmin, rmax, zmin, zmax, ar, az) < reach:
                n_before = n
                u0 = q1 + 2.0 * (z0 - az) * zd
                u1 = 2.0 * q2 + 2.0 * zd * zd
                r2 = ar * ar
                if ar == 0.0:  # a point on the axis: u = 0 (q = 0 is already a candidate)
                    if u1 != 0.0 and 0.0 <= -u0 / u1 <= 1.0:
                        cands[n] = -u0 / u1
                        n += 1
                else:
                    n = _quartic_unit_roots(
                        u0 * u0 * q0 - r2 * q1 * q1,
                        2.0 * u0 * u1 * q0 + u0 * u0 * q1 - 4.0 * r2 * q1 * q2,
                        u1 * u1 * q0 + 2.0 * u0 * u1 * q1 + u0 * u0 * q2 - 4.0 * r2 * q2 * q2,
                        u1 * u1 * q1 + 2.0 * u0 * u1 * q2,
                        u1 * u1 * q2,
                        cands,
                        n,
                    )
                for c in range(n_before, n):
                    dist = _feature_distance(q0, q1, q2, z0, zd, cands[c], ar, az, er, ez, False)
                    best_abs = min(best_abs, dist)
    if best_abs > _TOUCH and sdf_start > 0.0:
        return best_abs  # the segment never reaches the surface and starts outside
    best = np.inf
    for i in range(n):
        t = cands[i]
        qt = q0 + t * (q1 + t * q2)
        s = _polygon_sdf(math.sqrt(max(qt, 0.0)), z0 + t * zd, verts, boundary)
        if s < best:
            best = s
    # Inside the solid the depth is the distance to the *nearest* feature, whose largest value
    # can lie where two features are equally near, which no candidate marks; so every stretch
    # between consecutive candidates that lies inside is searched (golden section of the
    # signed distance) for a deeper point. The value stays one the segment attains.
    ts = np.sort(cands[:n])
    for i in range(n - 1):
        lo, hi = ts[i], ts[i + 1]
        if hi - lo <= 1e-12:
            continue
        mid = 0.5 * (lo + hi)
        qt = q0 + mid * (q1 + mid * q2)
        if _polygon_sdf(math.sqrt(max(qt, 0.0)), z0 + mid * zd, verts, boundary) >= 0.0:
            continue
        x1 = hi - _GOLDEN * (hi - lo)
        x2 = lo + _GOLDEN * (hi - lo)
        qa = q0 + x1 * (q1 + x1 * q2)
        f1 = _polygon_sdf(math.sqrt(max(qa, 0.0)), z0 + x1 * zd, verts, boundary)
        qb = q0 + x2 * (q1 + x2 * q2)
        f2 = _polygon_sdf(math.sqrt(max(qb, 0.0)), z0 + x2 * zd, verts, boundary)
        for _ in range(_INSIDE_GOLDEN):
            if f1 < f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - _GOLDEN * (hi - lo)
                qa = q0 + x1 * (q1 + x1 * q2)
                f1 = _polygon_sdf(math.sqrt(max(qa, 0.0)), z0 + x1 * zd, verts, boundary)
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + _GOLDEN * (hi - lo)
                qb = q0 + x2 * (q1 + x2 * q2)
                f2 = _polygon_sdf(math.sqrt(max(qb, 0.0)), z0 + x2 * zd, verts, boundary)
        best = min(best, f1, f2)
    return best


@njit(cache=True, nogil=True)
def segments_to_revolution(
    p0: np.ndarray,
    p1: np.ndarray,
    origin: np.ndarray,
    axis: np.ndarray,
    verts: np.ndarray,
    boundary: np.ndarray,
) -> np.ndarray:
    """Smallest signed distance of each segment ``p0[k] -> p1[k]`` to a solid of revolution."""
    k_count = p0.shape[0]
    out = np.empty(k_count)
    p = np.empty((k_count, 6))
    for k in range(k_count):  # element by element: slice assignment is slow to compile
        for i in range(3):
            p[k, i] = p0[k, i]
            p[k, 3 + i] = p1[k, i]
    n_chunks = min(k_count, 64)
    for c in range(n_chunks):
        cands = np.empty(8 + verts.shape[0] * 32)
        for k in range(c, k_count, n_chunks):
            out[k] = segment_revolution(p, k, origin, axis, verts, boundary, cands)
    return out


@njit(cache=True)
def points_to_revolution(
    x: np.ndarray, origin: np.ndarray, axis: np.ndarray, verts: np.ndarray, boundary: np.ndarray
) -> np.ndarray:
    """Signed distance of points ``x (K, 3)`` to a solid of revolution."""
    out = np.empty(x.shape[0])
    for k in range(x.shape[0]):
        a = x[k] - origin
        z = a[0] * axis[0] + a[1] * axis[1] + a[2] * axis[2]
        rp = a - z * axis
        r = math.sqrt(rp[0] * rp[0] + rp[1] * rp[1] + rp[2] * rp[2])
        out[k] = _polygon_sdf(r, z, verts, boundary)
    return out


@njit(cache=True)
def _box_sdf(x: np.ndarray, center: np.ndarray, rot: np.ndarray, half: np.ndarray) -> float:
    outside2 = 0.0
    inner = -np.inf
    for i in range(3):
        c = 0.0
        for j in range(3):
            c += rot[j, i] * (x[j] - center[j])
        e = abs(c) - half[i]
        if e > 0.0:
            outside2 += e * e
        if e > inner:
            inner = e
    if outside2 > 0.0:
        return math.sqrt(outside2)
    return inner


@njit(cache=True)
def _segment_box_outside2(
    p0: np.ndarray, p1: np.ndarray, k: int, center: np.ndarray, rot: np.ndarray, half: np.ndarray
) -> float:
    """Smallest squared distance of segment ``k`` to the box (0 when it touches or enters).

    In box coordinates the squared distance is a sum over axes of ``max(|x_i| - h_i, 0)^2``: a
    convex piecewise quadratic in ``t`` whose pieces end where a coordinate crosses a face plane.
    Each piece's quadratic is minimised in closed form.
    """
    la = np.empty(3)
    ld = np.empty(3)
    for i in range(3):
        sa, sd = 0.0, 0.0
        for j in range(3):
            sa += rot[j, i] * (p0[k, j] - center[j])
            sd += rot[j, i] * (p1[k, j] - p0[k, j])
        la[i], ld[i] = sa, sd
    brk = np.empty(8)
    nb = 0
    brk[nb] = 0.0
    nb += 1
    for i in range(3):
        if ld[i] != 0.0:
            for sgn in (-1.0, 1.0):
                t = (sgn * half[i] - la[i]) / ld[i]
                if 0.0 < t < 1.0:
                    brk[nb] = t
                    nb += 1
    brk[nb] = 1.0
    nb += 1
    for i in range(1, nb):  # insertion sort (at most 8 values)
        v = brk[i]
        j = i - 1
        while j >= 0 and brk[j] > v:
            brk[j + 1] = brk[j]
            j -= 1
        brk[j + 1] = v
    best = np.inf
    for piece in range(nb - 1):
        lo, hi = brk[piece], brk[piece + 1]
        mid = 0.5 * (lo + hi)
        qa, qb, qc = 0.0, 0.0, 0.0
        for i in range(3):
            x = la[i] + mid * ld[i]
            if x > half[i]:
                off = la[i] - half[i]
            elif x < -half[i]:
                off = la[i] + half[i]
            else:
                continue
            qa += ld[i] * ld[i]
            qb += 2.0 * off * ld[i]
            qc += off * off
        t = lo
        if qa > 0.0:
            t = min(max(-qb / (2.0 * qa), lo), hi)
        best = min(best, qc + t * (qb + t * qa), qc + lo * (qb + lo * qa), qc + hi * (qb + hi * qa))
    return max(best, 0.0)


@njit(cache=True)
def segments_to_box(
    p0: np.ndarray, p1: np.ndarray, center: np.ndarray, rot: np.ndarray, half: np.ndarray
) -> np.ndarray:
    """Smallest signed distance of each segment to an oriented box.

    ``rot`` columns are the box axes in world coordinates; ``half`` the half extents. Outside:
    exact closed form (:func:`_segment_box_outside2`). A segment that touches or enters the box
    has its (convex) signed distance minimised by golden-section search.
    """
    out = np.empty(p0.shape[0])
    x = np.empty(3)
    for k in range(p0.shape[0]):
        out[k] = segment_box(p0, p1, k, center, rot, half, x)
    return out


@njit(cache=True)
def segment_box(
    p0: np.ndarray,
    p1: np.ndarray,
    k: int,
    center: np.ndarray,
    rot: np.ndarray,
    half: np.ndarray,
    x: np.ndarray,
) -> float:  # pragma: no cover - compiled
    """:func:`segments_to_box` of segment ``p0[k] -> p1[k]`` (``x``: scratch of 3)."""
    d2 = _segment_box_outside2(p0, p1, k, center, rot, half)
    if d2 > 0.0:
        return math.sqrt(d2)
    lo, hi = 0.0, 1.0
    t1 = hi - _GOLDEN * (hi - lo)
    t2 = lo + _GOLDEN * (hi - lo)
    for j in range(3):
        x[j] = p0[k, j] + t1 * (p1[k, j] - p0[k, j])
    f1 = _box_sdf(x, center, rot, half)
    for j in range(3):
        x[j] = p0[k, j] + t2 * (p1[k, j] - p0[k, j])
    f2 = _box_sdf(x, center, rot, half)
    for _ in range(GOLDEN_ITERATIONS):
        if f1 < f2:
            hi, t2, f2 = t2, t1, f1
            t1 = hi - _GOLDEN * (hi - lo)
            for j in range(3):
                x[j] = p0[k, j] + t1 * (p1[k, j] - p0[k, j])
            f1 = _box_sdf(x, center, rot, half)
        else:
            lo, t1, f1 = t1, t2, f2
            t2 = lo + _GOLDEN * (hi - lo)
            for j in range(3):
                x[j] = p0[k, j] + t2 * (p1[k, j] - p0[k, j])
            f2 = _box_sdf(x, center, rot, half)
    best = min(f1, f2)
    for j in range(3):
        x[j] = p0[k, j]
    best = min(best, _box_sdf(x, center, rot, half))
    for j in range(3):
        x[j] = p1[k, j]
    return min(best, _box_sdf(x, center, rot, half))


@njit(cache=True)
def segment_segment_distance(
    a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray
) -> np.ndarray:
    """Smallest distance between segments ``a0[k]->a1[k]`` and ``b0[k]->b1[k]`` (exact).

    Minimises the convex quadratic ``|a(s) - b(t)|^2`` over the unit square: the unconstrained
    minimum if it lies inside, else the best of the four edge minima (each a clamped 1-D problem).
    """
    out = np.empty(a0.shape[0])
    for k in range(a0.shape[0]):
        out[k] = segment_segment(
            a0[k, 0], a0[k, 1], a0[k, 2], a1[k, 0], a1[k, 1], a1[k, 2],
            b0[k, 0], b0[k, 1], b0[k, 2], b1[k, 0], b1[k, 1], b1[k, 2],
        )  # fmt: skip
    return out


@njit(cache=True)
def indexed_segment_distances(
    points: np.ndarray, a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`segment_segment_distance` of segments ``points[m, a0[k]] -> points[m, a1[k]]``
    and ``points[m, b0[k]] -> points[m, b1[k]]`` for every ``m`` of ``points (M, L, 3)`` and
    ``k``: ``(M, K)``, without gathering the end points first."""
    out = np.empty((points.shape[0], a0.shape[0]))
    for m in range(points.shape[0]):
        for k in range(a0.shape[0]):
            out[m, k] = point_segments_distance(points[m], a0[k], a1[k], b0[k], b1[k])
    return out


@njit(cache=True)
def point_segments_distance(
    p: np.ndarray, i: int, j: int, g: int, h: int
) -> float:  # pragma: no cover - compiled
    """:func:`segment_segment` of segments ``p[i] -> p[j]`` and ``p[g] -> p[h]`` of points
    ``p (L, 3)`` (a pair of links between landmarks)."""
    return segment_segment(
        p[i, 0], p[i, 1], p[i, 2], p[j, 0], p[j, 1], p[j, 2],
        p[g, 0], p[g, 1], p[g, 2], p[h, 0], p[h, 1], p[h, 2],
    )  # fmt: skip


@njit(cache=True)
def segment_segment(
    a00: float,
    a01: float,
    a02: float,
    a10: float,
    a11: float,
    a12: float,
    b00: float,
    b01: float,
    b02: float,
    b10: float,
    b11: float,
    b12: float,
) -> float:  # pragma: no cover - compiled
    """:func:`segment_segment_distance` of one pair, from the end points' coordinates."""
    u0, u1, u2 = a10 - a00, a11 - a01, a12 - a02
    v0, v1, v2 = b10 - b00, b11 - b01, b12 - b02
    r0, r1, r2 = a00 - b00, a01 - b01, a02 - b02
    aa = u0 * u0 + u1 * u1 + u2 * u2
    ee = v0 * v0 + v1 * v1 + v2 * v2
    bb = u0 * v0 + u1 * v1 + u2 * v2
    cc = u0 * r0 + u1 * r1 + u2 * r2
    ff = v0 * r0 + v1 * r1 + v2 * r2
    best = np.inf
    den = aa * ee - bb * bb
    if den > 1e-12 * aa * ee and den > 0.0:
        s = (bb * ff - cc * ee) / den
        t = (aa * ff - bb * cc) / den
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            best = _pair_dist2(r0, r1, r2, u0, u1, u2, v0, v1, v2, s, t)
    # edges of the unit square: s = 0, s = 1 (optimise t); t = 0, t = 1 (optimise s)
    for s_fix in (0.0, 1.0):
        t = (ff + s_fix * bb) / ee if ee > 0.0 else 0.0
        t = min(max(t, 0.0), 1.0)
        best = min(best, _pair_dist2(r0, r1, r2, u0, u1, u2, v0, v1, v2, s_fix, t))
    for t_fix in (0.0, 1.0):
        s = (t_fix * bb - cc) / aa if aa > 0.0 else 0.0
        s = min(max(s, 0.0), 1.0)
        best = min(best, _pair_dist2(r0, r1, r2, u0, u1, u2, v0, v1, v2, s, t_fix))
    return math.sqrt(best)


@njit(cache=True, inline="always")
def _pair_dist2(
    r0: float,
    r1: float,
    r2: float,
    u0: float,
    u1: float,
    u2: float,
    v0: float,
    v1: float,
    v2: float,
    s: float,
    t: float,
) -> float:
    """``|r + s u - t v|^2``."""
    w0 = r0 + s * u0 - t * v0
    w1 = r1 + s * u1 - t * v1
    w2 = r2 + s * u2 - t * v2
    return w0 * w0 + w1 * w1 + w2 * w2


@njit(cache=True)
def segments_to_point(p0: np.ndarray, p1: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance of each segment ``p0[k] -> p1[k]`` to the point ``c[k]`` (all ``(K, 3)``)."""
    out = np.empty(p0.shape[0])
    for k in range(p0.shape[0]):
        out[k] = segment_point(p0, p1, k, c[k, 0], c[k, 1], c[k, 2])
    return out


@njit(cache=True)
def segment_point(
    p0: np.ndarray, p1: np.ndarray, k: int, c0: float, c1: float, c2: float
) -> float:  # pragma: no cover - compiled
    """Distance of segment ``p0[k] -> p1[k]`` to the point ``(c0, c1, c2)``."""
    d0, d1, d2 = p1[k, 0] - p0[k, 0], p1[k, 1] - p0[k, 1], p1[k, 2] - p0[k, 2]
    w0, w1, w2 = c0 - p0[k, 0], c1 - p0[k, 1], c2 - p0[k, 2]
    dd = d0 * d0 + d1 * d1 + d2 * d2
    t = (w0 * d0 + w1 * d1 + w2 * d2) / dd if dd > 0.0 else 0.0
    t = min(max(t, 0.0), 1.0)
    v0, v1, v2 = w0 - t * d0, w1 - t * d1, w2 - t * d2
    return math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
