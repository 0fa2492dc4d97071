"""An independent checker for SPEC Task 2 (trace the crack), written from the SPEC text only.

It shares no code with armpath. It reuses ``independent`` (forward kinematics, link lengths,
command replay) and adds:

- ``Crack``: the intersection of the workpiece's outer conical face with the plane x = 2z,
  parametrized by the angle ``phi`` about the workpiece axis (z solved in closed form), with arc
  length, dense sampling, closest points and ``distance``;
- ``signed_distance``: a fast numpy signed distance to the hollow truncated cone (checked against
  ``independent.Workpiece.distance`` by the tests), and ``clearance`` = min(workpiece, table);
- ``reach_margin`` / ``reachable_mask`` / ``blocking_analysis`` / ``boundary``: whether some arm
  configuration puts the fingertip E exactly on a crack point under the joint limits and the
  clearance rules, by searching the whole solution family: the wrist D on the sphere of radius DE
  about E (dense Fibonacci directions, then a shrinking-grid search around the best ones), joints
  1-3 in closed form for D (both arm sides, both elbows), joint 5 as the angle between CD and DE
  (joint 4 is unlimited, so every DE direction within that angle of CD is attained);
- ``replay_trace``: exact integer replay of a trace document and dense sampling of the continuous
  motion (tip deviation per pass, tool-tip and link-body clearances, covered arcs).

Clearance of a link is the minimum of a 1-Lipschitz function along it; it is sampled coarsely,
then the few sub-intervals whose Lipschitz lower bound could hold the minimum are resampled
finely (``_link_clearance``), so both a sampled value and a certified lower bound come out.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

import independent
from independent import AB, BC, CD, DE

# --- the seed scene (SPEC section 3) --------------------------------------------------------------
AXIS = np.array([210.0, 0.0])
HEIGHT, R_BOTTOM, R_TOP, WALL = 180.0, 168.0, 96.0, 8.0
SLOPE = (R_BOTTOM - R_TOP) / HEIGHT  # 0.4: the outer radius shrinks 0.4 mm per mm of height
MARGIN = 1.0  # required clearance of the link bodies to workpiece and table
TIP = 5.0  # the last 5 mm of DE are the tool tip: no margin, but no penetration
LIM2, LIM3, LIM5 = 125.0, 138.0, 133.5
TIP_SCALE = 100.0  # tool-direction margin (a cosine) in the same rough scale as mm and degrees


# --- the workpiece --------------------------------------------------------------------------------
def _section(wall_thickness: str = "normal") -> np.ndarray:
    """The surface in the half plane (r, z) as 5 segments (the axis is not surface)."""
    dw = WALL * np.hypot(1.0, SLOPE) if wall_thickness == "normal" else WALL
    r_in_top = R_TOP - dw
    r_in_floor = R_BOTTOM - SLOPE * WALL - dw
    poly = np.array(
        [
            (0.0, 0.0),
            (R_BOTTOM, 0.0),
            (R_TOP, HEIGHT),
            (r_in_top, HEIGHT),
            (r_in_floor, WALL),
            (0.0, WALL),
        ]
    )
    return np.stack([poly[:-1], poly[1:]], axis=1)  # (5, 2, 2)


_SECTIONS = {w: _section(w) for w in ("normal", "horizontal")}
_DW = {"normal": WALL * np.hypot(1.0, SLOPE), "horizontal": WALL}


def signed_distance(p: np.ndarray, wall_thickness: str = "normal") -> np.ndarray:
    """Signed distance (mm) of points (..., 3) to the workpiece; negative inside the material."""
    p = np.asarray(p, dtype=float)
    r = np.hypot(p[..., 0] - AXIS[0], p[..., 1] - AXIS[1])
    z = p[..., 2]
    segs = _SECTIONS[wall_thickness]
    d = np.full(r.shape, np.inf)
    for (ar, az), (br, bz) in segs:
        er, ez = br - ar, bz - az
        t = np.clip(((r - ar) * er + (z - az) * ez) / (er * er + ez * ez), 0.0, 1.0)
        d = np.minimum(d, np.hypot(r - ar - t * er, z - az - t * ez))
    dw = _DW[wall_thickness]  # r_out(z) - r_in(z)
    r_out = R_BOTTOM - SLOPE * z
    inside = (z >= 0) & (z <= HEIGHT) & (r <= r_out) & ((z <= WALL) | (r >= r_out - dw))
    return np.where(inside, -d, d)


def clearance(p: np.ndarray, wall_thickness: str = "normal") -> np.ndarray:
    """min(signed distance to the workpiece, height above the table) of points (..., 3)."""
    p = np.asarray(p, dtype=float)
    return np.minimum(signed_distance(p, wall_thickness), p[..., 2])


def outer_normal(p: np.ndarray) -> np.ndarray:
    """Outward unit normal of the outer conical face at (or radially through) points (..., 3)."""
    p = np.asarray(p, dtype=float)
    dx, dy = p[..., 0] - AXIS[0], p[..., 1] - AXIS[1]
    r = np.hypot(dx, dy)
    n = np.stack([dx / r, dy / r, np.full(r.shape, SLOPE)], axis=-1)
    return n / np.hypot(1.0, SLOPE)


# --- the crack ------------------------------------------------------------------------------------
class Crack:
    """Outer conical face ∩ plane x = 2z, parametrized by the angle phi about the workpiece axis.

    On the outer face r(z) = 168 - 0.4 z, x = 210 + r cos(phi), y = r sin(phi); x = 2z gives
    z(phi) = (210 + 168 cos phi) / (2 + 0.4 cos phi), a closed smooth curve from z = 157.5 at
    phi = 0, the point (315, 0, 157.5), to z = 26.25 at phi = pi, the point (52.5, 0, 26.25).
    Arc length s is measured from phi = 0 in the direction ``direction`` (+1: increasing phi,
    i.e. y > 0 first).
    """

    def __init__(self, direction: int = 1, n_table: int = 400_001, n_poly: int = 60_000) -> None:
        if direction not in (1, -1):
            raise ValueError("direction must be +1 or -1")
        self.direction = direction
        u = np.linspace(0.0, 2 * np.pi, n_table)
        speed = np.linalg.norm(self.derivative(u), axis=-1)
        ds = 0.5 * (speed[1:] + speed[:-1]) * np.diff(u)
        self._u = u
        self._s = np.concatenate([[0.0], np.cumsum(ds)])
        self.length = float(self._s[-1])
        s_poly = np.linspace(0.0, self.length, n_poly + 1)
        self.poly = self.at(s_poly)  # closed: poly[-1] == poly[0]
        self.poly_s = s_poly
        self._tree = cKDTree(self.poly[:-1])

    def point_phi(self, phi: np.ndarray) -> np.ndarray:
        phi = np.asarray(phi, dtype=float)
        c = np.cos(phi)
        z = (210.0 + 168.0 * c) / (2.0 + 0.4 * c)
        r = R_BOTTOM - SLOPE * z
        return np.stack([AXIS[0] + r * c, AXIS[1] + r * np.sin(phi), z], axis=-1)

    def derivative(self, u: np.ndarray) -> np.ndarray:
        """d point / d u, where phi = direction * u."""
        phi = self.direction * np.asarray(u, dtype=float)
        c, sn = np.cos(phi), np.sin(phi)
        z = (210.0 + 168.0 * c) / (2.0 + 0.4 * c)
        # dz/dphi = [-168 sn (2 + 0.4 c) + 0.4 sn (210 + 168 c)] / (2 + 0.4 c)^2
        dz = (-168.0 * sn * (2.0 + 0.4 * c) + 0.4 * sn * (210.0 + 168.0 * c)) / (2.0 + 0.4 * c) ** 2
        r = R_BOTTOM - SLOPE * z
        dr = -SLOPE * dz
        dp = np.stack([dr * c - r * sn, dr * sn + r * c, dz], axis=-1)
        return dp * np.asarray(self.direction, dtype=float)

    def phi_of_s(self, s: np.ndarray) -> np.ndarray:
        s = np.mod(np.asarray(s, dtype=float), self.length)
        return self.direction * np.interp(s, self._s, self._u)

    def at(self, s: np.ndarray) -> np.ndarray:
        """Points (..., 3) at arc lengths s (taken modulo the length)."""
        return self.point_phi(self.phi_of_s(s))

    def sample(self, spacing: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Equally spaced (s, points), spacing at most ``spacing``, s in [0, length)."""
        n = int(np.ceil(self.length / spacing))
        s = np.arange(n) * (self.length / n)
        return s, self.at(s)

    def closest(self, p: np.ndarray, k: int = 6) -> tuple[np.ndarray, np.ndarray]:
        """(distance, arc length of the closest curve point) for points (..., 3).

        Exact point-segment distance to the dense polyline (60 000 chords, ~0.015 mm each: the
        chord error is below 1e-6 mm), among the segments next to the k nearest vertices.
        """
        p = np.asarray(p, dtype=float)
        flat = p.reshape(-1, 3)
        n = len(self.poly) - 1
        _, idx = self._tree.query(flat, k=k)
        idx = np.atleast_2d(idx)
        seg = np.concatenate([idx, idx - 1], axis=1) % n  # segments [i, i+1]
        a, b = self.poly[seg], self.poly[seg + 1]
        ab = b - a
        t = np.clip(
            np.einsum("mkj,mkj->mk", flat[:, None] - a, ab) / np.einsum("mkj,mkj->mk", ab, ab),
            0.0,
            1.0,
        )
        d = np.linalg.norm(flat[:, None] - a - t[..., None] * ab, axis=-1)
        j = np.argmin(d, axis=1)
        rows = np.arange(len(flat))
        s = self.poly_s[seg[rows, j]] + t[rows, j] * (self.poly_s[1] - self.poly_s[0])
        return d[rows, j].reshape(p.shape[:-1]), s.reshape(p.shape[:-1])

    def distance(self, p: np.ndarray) -> np.ndarray:
        return self.closest(p)[0]

    @classmethod
    def aligned_to(cls, points_mm: Any) -> Crack:
        """The crack with s = 0 at points_mm[0] = (315, 0, 157.5), running towards points_mm[1]."""
        pts = np.asarray(points_mm, dtype=float)
        if np.linalg.norm(pts[0] - [315.0, 0.0, 157.5]) > 1e-6:
            raise ValueError(f"the curve does not start at (315, 0, 157.5): {pts[0]}")
        return cls(1 if pts[1, 1] > 0 else -1)


def distance_to_crack(p: np.ndarray, crack: Crack | None = None) -> np.ndarray:
    return (crack or _default_crack()).distance(p)


_CRACKS: dict[int, Crack] = {}


def _default_crack(direction: int = 1) -> Crack:
    if direction not in _CRACKS:
        _CRACKS[direction] = Crack(direction)
    return _CRACKS[direction]


# --- link clearance with a Lipschitz bound -----------------------------------------------------
def _link_clearance(
    a: np.ndarray,
    b: np.ndarray,
    coarse: float = 5.0,
    fine: int = 32,
    keep: int = 6,
    wall_thickness: str = "normal",
) -> tuple[np.ndarray, np.ndarray]:
    """(sampled minimum, certified lower bound) of ``clearance`` along segments a[m] -> b[m].

    All segments of one call have the same length (the links are rigid). ``clearance`` is
    1-Lipschitz, so on a sub-interval of length h with end values d0, d1 the minimum is at least
    (d0 + d1 - h) / 2; the ``keep`` sub-intervals with the smallest such bound are resampled with
    ``fine`` points each.
    """
    length = float(np.linalg.norm(b[0] - a[0])) if len(a) else 0.0
    if len(a) == 0:
        return np.zeros(0), np.zeros(0)
    n = max(1, int(np.ceil(length / coarse)))
    h = length / n
    t = np.linspace(0.0, 1.0, n + 1)
    ab = b - a
    d = clearance(a[:, None] + t[None, :, None] * ab[:, None], wall_thickness)  # (m, n+1)
    lb_int = 0.5 * (d[:, :-1] + d[:, 1:] - h)  # (m, n)
    keep = min(keep, n)
    order = np.argsort(lb_int, axis=1)
    chosen = order[:, :keep]  # (m, keep)
    rest_lb = (
        np.take_along_axis(lb_int, order[:, keep : keep + 1], axis=1)[:, 0]
        if keep < n
        else np.full(len(a), np.inf)
    )
    tf = (chosen[..., None] + np.linspace(0.0, 1.0, fine + 1)) / n  # (m, keep, fine+1)
    pf = a[:, None, None] + tf[..., None] * ab[:, None, None]
    df = clearance(pf, wall_thickness)
    hf = h / fine
    lb_f = 0.5 * (df[..., :-1] + df[..., 1:] - hf).min(axis=(1, 2))
    value = np.minimum(d.min(axis=1), df.min(axis=(1, 2)))
    return value, np.minimum(lb_f, rest_lb)


def body_clearance(
    P: np.ndarray, wall_thickness: str = "normal", fine: int = 32
) -> tuple[np.ndarray, np.ndarray]:
    """(sampled, lower bound) minimum clearance of BC, CD and DE without its last 5 mm.

    P: (m, 5, 3) points A..E. AB is fixed: its clearance to the workpiece is 42 mm (the base is
    on the table, so AB is not checked against the table).
    """
    B, C, D, E = P[:, 1], P[:, 2], P[:, 3], P[:, 4]
    T = E + (D - E) * (TIP / DE)  # start of the tool tip
    vals, lbs = [], []
    for a, b in ((B, C), (C, D), (D, T)):
        v, lb = _link_clearance(a, b, fine=fine, wall_thickness=wall_thickness)
        vals.append(v)
        lbs.append(lb)
    return np.min(vals, axis=0), np.min(lbs, axis=0)


def tip_clearance(P: np.ndarray, wall_thickness: str = "normal", n: int = 41) -> np.ndarray:
    """Minimum signed clearance over the tool tip (last 5 mm of DE, E included), sampled."""
    D, E = P[:, 3], P[:, 4]
    t = np.linspace(0.0, TIP / DE, n)
    pts = E[:, None] + t[None, :, None] * (D - E)[:, None]
    return clearance(pts, wall_thickness).min(axis=1)


# --- the solution family for a fingertip position ------------------------------------------------
def fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    a = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=-1)


@dataclass
class _Family:
    """Configurations for wrist directions U (k, 3) and the 4 branches (arm side x elbow)."""

    E: np.ndarray
    U: np.ndarray  # unit directions from E to the wrist D
    valid: np.ndarray  # (k, 4)
    theta: np.ndarray  # (k, 4, 3): joints 1-3, degrees
    a5: np.ndarray  # (k, 4) angle between CD and DE, degrees
    C: np.ndarray  # (k, 4, 3)
    D: np.ndarray  # (k, 3)
    cheap: dict[str, np.ndarray] = field(default_factory=dict)  # margins without collision


def _family(E: np.ndarray, U: np.ndarray) -> _Family:
    D = E + DE * U
    rho = np.hypot(D[:, 0], D[:, 1])
    v = D[:, 2] - AB
    c3 = (rho**2 + v**2 - BC**2 - CD**2) / (2 * BC * CD)
    valid1 = c3 <= 1.0
    t3 = np.arccos(np.clip(c3, -1.0, 1.0))
    thetas, Cs, a5s, valids = [], [], [], []
    for side in (1.0, -1.0):
        w = side * rho
        t1 = np.arctan2(side * D[:, 0], -side * D[:, 1])
        for elbow in (1.0, -1.0):
            th3 = elbow * t3
            # BC at angle t2 from the vertical, CD at t2 + t3; both links are 255 mm, so the
            # wrist's direction from B bisects them: t2 = atan2(w, v) - t3 / 2
            th2 = np.arctan2(w, v) - th3 / 2
            th2 = np.mod(th2 + np.pi, 2 * np.pi) - np.pi
            s1, c1 = np.sin(t1), np.cos(t1)
            C = np.stack(
                [s1 * BC * np.sin(th2), -c1 * BC * np.sin(th2), AB + BC * np.cos(th2)], axis=-1
            )
            cd = (D - C) / CD
            # DE points from D to E, i.e. along -U
            a5 = np.degrees(np.arccos(np.clip(-np.einsum("kj,kj->k", cd, U), -1.0, 1.0)))
            thetas.append(np.degrees(np.stack([t1, th2, th3], axis=-1)))
            Cs.append(C)
            a5s.append(a5)
            valids.append(valid1)
    fam = _Family(
        E=E,
        U=U,
        valid=np.stack(valids, axis=1),
        theta=np.stack(thetas, axis=1),
        a5=np.stack(a5s, axis=1),
        C=np.stack(Cs, axis=1),
        D=D,
    )
    n = outer_normal(E)
    neg = np.where(fam.valid, 0.0, -np.inf)
    fam.cheap = {
        "j2": LIM2 - np.abs(fam.theta[..., 1]) + neg,
        "j3": LIM3 - np.abs(fam.theta[..., 2]) + neg,
        "j5": LIM5 - fam.a5 + neg,
        "tip": np.broadcast_to((TIP_SCALE * (U @ n))[:, None], fam.valid.shape) + neg,
    }
    return fam


def _coll_margin(
    fam: _Family, rows: np.ndarray, cols: np.ndarray, wall_thickness: str
) -> np.ndarray:
    """Body clearance minus the 1 mm margin for the configurations (rows, cols)."""
    m = len(rows)
    P = np.empty((m, 5, 3))
    P[:, 0] = 0.0
    P[:, 1] = (0.0, 0.0, AB)
    P[:, 2] = fam.C[rows, cols]
    P[:, 3] = fam.D[rows]
    P[:, 4] = fam.E
    out = np.empty(m)
    for k in range(0, m, 4096):
        out[k : k + 4096] = body_clearance(P[k : k + 4096], wall_thickness)[0] - MARGIN
    return out


CONSTRAINTS = ("j2", "j3", "j5", "tip", "coll")


@dataclass
class Margin:
    """Best value over the solution family of min(margins of the active constraints)."""

    value: float
    config_deg: np.ndarray | None  # theta1..theta5 (theta6 = 0) of the best configuration
    constraints: tuple[str, ...]


def _objective(
    fam: _Family, active: tuple[str, ...], wall_thickness: str, stop_positive: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Branch and bound: (rows, cols, values) of the evaluated configurations."""
    cheap_keys = [c for c in active if c != "coll"]
    cheap = (
        np.min([fam.cheap[c] for c in cheap_keys], axis=0)
        if cheap_keys
        else np.where(fam.valid, np.inf, -np.inf)
    )
    rows, cols = np.nonzero(fam.valid)
    vals = cheap[rows, cols]
    if "coll" not in active:
        return rows, cols, vals
    order = np.argsort(-vals, kind="stable")
    rows, cols, vals = rows[order], cols[order], vals[order]
    best = -np.inf
    out = np.full(len(vals), -np.inf)
    done = 0
    batch = 256
    while done < len(vals) and vals[done] > best:
        sl = slice(done, done + batch)
        cm = _coll_margin(fam, rows[sl], cols[sl], wall_thickness)
        out[sl] = np.minimum(vals[sl], cm)
        best = max(best, float(out[sl].max()))
        done += batch
        if stop_positive and best >= 0:
            break
        batch = min(batch * 2, 16384)
    return rows[:done], cols[:done], out[:done]


def _tangent_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(u, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(u, e1)


def _config(fam: _Family, row: int, col: int) -> np.ndarray:
    """theta1..theta5 (degrees) of one configuration, theta4/theta5 from the DE direction."""
    t1, t2, t3 = np.radians(fam.theta[row, col])
    R3 = independent.rz(np.array(t1)) @ independent.rx(np.array(t2 + t3))
    ul = R3.T @ -fam.U[row]  # the DE direction in the frame of CD
    t5 = np.arccos(np.clip(ul[2], -1.0, 1.0))
    t4 = np.arctan2(ul[0], -ul[1]) if np.sin(t5) > 1e-12 else 0.0
    return np.degrees([t1, t2, t3, t4, t5])


def reach_margin(
    E: np.ndarray,
    active: tuple[str, ...] = CONSTRAINTS,
    n_dirs: int = 20000,
    refine: bool = True,
    stop_positive: bool = False,
    n_starts: int = 12,
    iterations: int = 14,
    wall_thickness: str = "normal",
) -> Margin:
    """Max over the solution family of min(margins), margins: limits in degrees, body clearance
    minus 1 in mm, tool direction 100 * cos(angle to the outward normal) (the tool tip of a
    fingertip on the outer face stays outside the convex outer frustum, hence outside the
    workpiece, iff DE points to the outer side of the tangent plane). Reachable iff >= 0.

    A dense Fibonacci set of wrist directions is searched by branch and bound (collision margins
    only where the cheap margins could beat the best so far); then the best configurations (the
    top ones of every branch) are improved by a shrinking 7 x 7 grid in the tangent plane of the
    sphere, branch fixed.
    """
    E = np.asarray(E, dtype=float)
    U = fibonacci_sphere(n_dirs)
    fam = _family(E, U)
    if not fam.valid.any():
        return Margin(-np.inf, None, active)
    rows, cols, vals = _objective(fam, active, wall_thickness, stop_positive)
    k = int(np.argmax(vals))
    best_val, best_cfg = float(vals[k]), _config(fam, int(rows[k]), int(cols[k]))
    if not refine or (stop_positive and best_val >= 0):
        return Margin(best_val, best_cfg, active)
    # starting points: the best few of each branch
    starts_u, starts_b = [], []
    for b in range(4):
        sel = np.nonzero(cols == b)[0]
        if sel.size == 0:
            continue
        top = sel[np.argsort(-vals[sel])[: max(1, n_starts // 4)]]
        top = top[np.isfinite(vals[top])]
        starts_u.append(U[rows[top]])
        starts_b.append(np.full(top.size, b))
    if not starts_u:
        return Margin(best_val, best_cfg, active)
    cu = np.concatenate(starts_u)
    cb = np.concatenate(starts_b)
    cv = np.full(len(cu), -np.inf)
    g = np.linspace(-1.0, 1.0, 7)
    ga, gb = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    radius = 1.5 * np.sqrt(4 * np.pi / n_dirs)
    for _ in range(iterations):
        e1, e2 = _tangent_basis(cu)
        cand = cu[:, None] + radius * (
            ga[None, :, None] * e1[:, None] + gb[None, :, None] * e2[:, None]
        )
        cand /= np.linalg.norm(cand, axis=-1, keepdims=True)
        flat = cand.reshape(-1, 3)
        f = _family(E, flat)
        bcol = np.repeat(cb, len(ga))
        rr = np.arange(len(flat))
        cheap_keys = [c for c in active if c != "coll"]
        v = np.full(len(flat), np.inf)
        for c in cheap_keys:
            v = np.minimum(v, f.cheap[c][rr, bcol])
        v = np.where(f.valid[rr, bcol], v, -np.inf)
        if "coll" in active:
            ok = np.isfinite(v) | (v == np.inf)
            ok &= f.valid[rr, bcol]
            # only where the cheap margins can still beat the start's value
            ok &= v > np.repeat(cv, len(ga))
            cm = np.full(len(flat), -np.inf)
            if ok.any():
                cm[ok] = _coll_margin(f, rr[ok], bcol[ok], wall_thickness)
            v = np.minimum(v, cm)
        v = v.reshape(len(cu), len(ga))
        j = np.argmax(v, axis=1)
        vj = v[np.arange(len(cu)), j]
        better = vj > cv
        cu = np.where(better[:, None], cand[np.arange(len(cu)), j], cu)
        cv = np.where(better, vj, cv)
        if stop_positive and cv.max() >= 0:
            break
        radius *= 0.6
    k = int(np.argmax(cv))
    if cv[k] > best_val:
        f = _family(E, cu[k : k + 1])
        best_val, best_cfg = float(cv[k]), _config(f, 0, int(cb[k]))
    return Margin(best_val, best_cfg, active)


def reachable_at(s: float, crack: Crack, **kw: Any) -> bool:
    return reach_margin(crack.at(s), stop_positive=True, **kw).value >= 0.0


LIMIT_KEYS = ("j2", "j3", "j5")
COLLISION_KEYS = ("tip", "coll")


def blocking_analysis(E: np.ndarray, n_dirs: int = 20000, **kw: Any) -> dict[str, Any]:
    """Which constraints block the fingertip position E.

    ``relaxed``: for each constraint group, whether E becomes reachable when that group alone is
    ignored; ``alone``: whether that group alone (all others ignored) blocks E. ``reason`` is one of
    'reachable', 'out of reach', 'joint limits' (limits alone block, a collision-free
    configuration exists), 'collision' (collisions alone block, a configuration within the limits
    exists), 'joint limits and collision, each alone', 'joint limits with collision'
    (neither alone blocks, only together).
    """
    E = np.asarray(E, dtype=float)

    def ok(active: tuple[str, ...]) -> bool:
        return reach_margin(E, active, n_dirs=n_dirs, stop_positive=True, **kw).value >= 0

    fam = _family(E, fibonacci_sphere(n_dirs))
    if not fam.valid.any():
        return {"reason": "out of reach", "relaxed": {}, "alone": {}}
    if ok(CONSTRAINTS):
        return {"reason": "reachable", "relaxed": {}, "alone": {}}
    groups = {
        "joint 2 limit": ("j2",),
        "joint 3 limit": ("j3",),
        "joint 5 limit": ("j5",),
        "joint limits": LIMIT_KEYS,
        "collision": COLLISION_KEYS,
    }
    relaxed = {
        name: ok(tuple(c for c in CONSTRAINTS if c not in keys)) for name, keys in groups.items()
    }
    alone = {name: not ok(keys) for name, keys in groups.items()}
    lim, col = alone["joint limits"], alone["collision"]
    if lim and col:
        reason = "joint limits and collision, each alone"
    elif lim:
        reason = "joint limits"
    elif col:
        reason = "collision"
    else:
        reason = "joint limits with collision"
    return {"reason": reason, "relaxed": relaxed, "alone": alone}


def reachable_mask(
    s_values: Any,
    crack: Crack | None = None,
    n_dirs: int = 20000,
    reasons: bool = True,
    **kw: Any,
) -> tuple[np.ndarray, list[str | None]]:
    """Reachability of the crack points at arc lengths ``s_values`` and, for the unreachable ones
    (if ``reasons``), the coarse reason of ``blocking_analysis``."""
    crack = crack or _default_crack()
    s_values = np.atleast_1d(np.asarray(s_values, dtype=float))
    mask = np.array([reachable_at(float(s), crack, n_dirs=n_dirs, **kw) for s in s_values])
    why: list[str | None] = [None] * len(s_values)
    if reasons:
        for i in np.nonzero(~mask)[0]:
            why[i] = blocking_analysis(crack.at(float(s_values[i])), n_dirs=n_dirs, **kw)["reason"]
    return mask, why


def boundary(s_in: float, s_out: float, crack: Crack, tol: float = 0.05, **kw: Any) -> float:
    """Bisection for the reach boundary between s_in (reachable) and s_out (not)."""
    if not reachable_at(s_in, crack, **kw) or reachable_at(s_out, crack, **kw):
        raise ValueError(f"[{s_in}, {s_out}] does not bracket a reach boundary")
    while abs(s_out - s_in) > tol:
        mid = 0.5 * (s_in + s_out)
        if reachable_at(mid, crack, **kw):
            s_in = mid
        else:
            s_out = mid
    return 0.5 * (s_in + s_out)


def boundary_near(
    s_guess: float,
    towards_reachable: float,
    crack: Crack,
    step: float = 2.0,
    max_steps: int = 40,
    tol: float = 0.05,
    **kw: Any,
) -> float:
    """The reach boundary nearest ``s_guess`` on its side: walks in ``step`` mm steps (towards
    the reachable side if s_guess is unreachable, away from it if reachable) until the status
    flips, then bisects. ``towards_reachable`` is +1 or -1 (direction of increasing s or not)."""
    sign = 1.0 if towards_reachable > 0 else -1.0
    here = reachable_at(s_guess, crack, **kw)
    walk = -sign if here else sign
    s_prev = s_guess
    for k in range(1, max_steps + 1):
        s_next = s_guess + walk * step * k
        if reachable_at(s_next, crack, **kw) != here:
            s_in, s_out = (s_prev, s_next) if here else (s_next, s_prev)
            return boundary(s_in, s_out, crack, tol=tol, **kw)
        s_prev = s_next
    raise ValueError(f"no reach boundary within {step * max_steps} mm of s = {s_guess}")


def arcs_of_mask(s: np.ndarray, mask: np.ndarray, length: float) -> list[tuple[float, float]]:
    """Maximal runs of True over equally spaced samples s of a closed curve, as (first, last)
    sample positions with last > first possibly beyond ``length`` (wrapping past s = 0)."""
    n = len(mask)
    if mask.all():
        return [(0.0, length)]
    if not mask.any():
        return []
    start = int(np.nonzero(~mask)[0][0])  # begin scanning after a False
    runs: list[tuple[float, float]] = []
    i = 0
    while i < n:
        k = (start + i) % n
        if mask[k]:
            j = i
            while j + 1 < n and mask[(start + j + 1) % n]:
                j += 1
            a = s[k]
            b = s[(start + j) % n]
            if b < a:
                b += length
            runs.append((float(a), float(b)))
            i = j + 1
        else:
            i += 1
    return sorted(runs)


# --- replay of a trace document -------------------------------------------------------------------
TICK_LIMITS = np.array([np.inf, 1250, 1380, np.inf, 1335, np.inf])


@dataclass
class TraceReplay:
    problems: list[str]
    states_ticks: np.ndarray
    pass_max_deviation: list[float]
    min_tip_clearance: float
    min_body_clearance: float
    min_body_clearance_lower_bound: float
    min_self_distance: float
    covered: list[list[tuple[float, float]]]  # per pass: union of swept arcs (start, end)
    crack: Crack

    @property
    def max_deviation(self) -> float:
        return max(self.pass_max_deviation, default=0.0)


def _interp_states(states: np.ndarray, cmd: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Joint angles (degrees) at fractions t in [0, 1] of the commands ``cmd`` (indices)."""
    a = states[cmd]
    b = states[cmd + 1]
    return (a[:, None] + t[None, :, None] * (b - a)[:, None]).reshape(-1, 6) / 10.0


def segment_distance(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Exact distance between segments p0-p1 and q0-q1 (arrays (..., 3), non-degenerate).

    Closest points of the two lines, clamped to the segments: s from the normal equations, then t
    for that s, then s again if t was clamped.
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...j,...j->...", d1, d1)
    e = np.einsum("...j,...j->...", d2, d2)
    b = np.einsum("...j,...j->...", d1, d2)
    c = np.einsum("...j,...j->...", d1, r)
    f = np.einsum("...j,...j->...", d2, r)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 1e-12 * a * e, np.clip((b * f - c * e) / den, 0.0, 1.0), 0.0)
    t = (b * s + f) / e
    s = np.where(
        t < 0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1, np.clip((b - c) / a, 0.0, 1.0), s)
    )
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p0 + s[..., None] * d1 - q0 - t[..., None] * d2, axis=-1)


def _self_distance(P: np.ndarray) -> np.ndarray:
    """Minimum distance between non-adjacent links (AB-CD, AB-DE, BC-DE) of configurations P."""
    pairs = (((0, 1), (2, 3)), ((0, 1), (3, 4)), ((1, 2), (3, 4)))
    return np.min(
        [segment_distance(P[:, i], P[:, j], P[:, k], P[:, m]) for (i, j), (k, m) in pairs], axis=0
    )


def _swept_arcs(s: np.ndarray, within: np.ndarray, length: float) -> list[tuple[float, float]]:
    """Arc-length ranges swept by consecutive samples inside the tolerance, merged."""
    un = np.unwrap(s * (2 * np.pi / length)) * (length / (2 * np.pi))
    arcs: list[tuple[float, float]] = []
    i, n = 0, len(s)
    while i < n:
        if not within[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and within[j + 1]:
            j += 1
        if j > i:
            a, b = float(un[i : j + 1].min()), float(un[i : j + 1].max())
            b = min(b, a + length)
            shift = np.floor(a / length) * length
            arcs.append((a - shift, b - shift))
        i = j + 1
    return union_arcs(arcs, length)


def union_arcs(arcs: list[tuple[float, float]], length: float) -> list[tuple[float, float]]:
    """Union of arcs (a, b), a in [0, length), a < b <= a + length, on a closed curve."""
    if not arcs:
        return []
    segs = []
    for a, b in arcs:
        a0 = a % length
        b0 = a0 + (b - a)
        segs.append((a0, b0))
        if b0 > length:
            segs.append((a0 - length, b0 - length))
    segs.sort()
    merged: list[list[float]] = []
    for a, b in segs:
        if merged and a <= merged[-1][1] + 1e-9:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    # keep the pieces inside [0, length), joining the one that wraps
    pieces = [(max(a, 0.0), min(b, length)) for a, b in merged if b > 0 and a < length]
    if len(pieces) > 1 and pieces[0][0] <= 1e-9 and pieces[-1][1] >= length - 1e-9:
        first = pieces.pop(0)
        last = pieces.pop()
        pieces.append((last[0], length + first[1]))
    if len(pieces) == 1 and pieces[0][1] - pieces[0][0] >= length - 1e-9:
        return [(0.0, length)]
    return sorted(pieces)


def _refine_extreme(
    states: np.ndarray,
    cmd: int,
    frac: np.ndarray,
    k: int,
    fn: Any,
    sign: float,
    n: int = 201,
) -> float:
    """Resample command ``cmd`` between the samples around index k; extreme of sign * fn."""
    lo, hi = frac[max(k - 1, 0)], frac[min(k + 1, len(frac) - 1)]
    t = np.linspace(lo, hi, n)
    P = independent.points(_interp_states(states, np.array([cmd]), t))
    return float((sign * fn(P)).max() * sign)


def replay_trace(
    doc: dict[str, Any],
    crack: Crack | None = None,
    substeps: int = 100,
    wall_thickness: str | None = None,
    refine_top: int = 8,
) -> TraceReplay:
    """Replay a trace document (SPEC Task 2) exactly and sample its continuous motion.

    Every command is sampled at ``substeps`` + 1 instants; the commands holding the extreme
    values (the ``refine_top`` worst ones) are resampled 200 times finer around the extreme.
    """
    problems: list[str] = []
    wall_thickness = wall_thickness or doc.get("wall_thickness", "normal")
    wall_thickness = "horizontal" if "horizontal" in str(wall_thickness) else "normal"
    crack = crack or Crack.aligned_to(doc["curve"]["points_mm"])
    cmds = np.asarray(doc["commands"])
    if cmds.size and cmds.dtype.kind != "i":
        if not np.all(cmds == np.rint(cmds)):
            problems.append("commands are not integers")
        cmds = np.rint(cmds).astype(int)
    cmds = cmds.reshape(-1, 6).astype(np.int64)
    if np.abs(cmds).max(initial=0) > 20:
        problems.append("a command increment is outside [-20, 20] ticks")
    if doc.get("n_commands") != len(cmds):
        problems.append("n_commands does not match the commands")
    init = np.asarray(doc["initial_deg"], dtype=float) * 10
    if not np.allclose(init, np.rint(init), atol=1e-9):
        problems.append("the initial state is not on the 0.1 degree lattice")
    states = np.vstack([np.rint(init), np.rint(init) + np.cumsum(cmds, axis=0)]).astype(np.int64)
    if np.any(np.abs(states) > TICK_LIMITS):
        problems.append("a joint limit is exceeded (the motion is linear: the states bound it)")
    if "final_deg" in doc and not np.allclose(states[-1] / 10, doc["final_deg"], atol=1e-9):
        problems.append("final_deg does not match the replayed commands")
    n_cmd = len(cmds)
    frac = np.linspace(0.0, 1.0, substeps + 1)
    pass_dev: list[float] = []
    covered: list[list[tuple[float, float]]] = []
    tol = float(doc["tolerance_mm"])
    body_min, body_lb, tip_min, self_min = np.inf, np.inf, np.inf, np.inf
    if n_cmd:
        allc = np.arange(n_cmd)
        P = independent.points(_interp_states(states.astype(float), allc, frac))  # (n*(k+1),5,3)
        body, lb = body_clearance(P, wall_thickness)
        tip = tip_clearance(P, wall_thickness)
        selfd = _self_distance(P)
        shape = (n_cmd, substeps + 1)
        body, lb, tip, selfd = (x.reshape(shape) for x in (body, lb, tip, selfd))
        fl = states.astype(float)
        body_min, body_lb = float(body.min()), float(lb.min())
        tip_min, self_min = float(tip.min()), float(selfd.min())
        for c in np.argsort(body.min(axis=1))[:refine_top]:
            k = int(np.argmin(body[c]))
            v = _refine_extreme(
                fl, int(c), frac, k, lambda Q: body_clearance(Q, wall_thickness, 64)[0], -1.0
            )
            body_min = min(body_min, v)
        for c in np.argsort(tip.min(axis=1))[:refine_top]:
            k = int(np.argmin(tip[c]))
            v = _refine_extreme(
                fl, int(c), frac, k, lambda Q: tip_clearance(Q, wall_thickness, 201), -1.0
            )
            tip_min = min(tip_min, v)
        E = P[:, 4].reshape(n_cmd, substeps + 1, 3)
        for i, j in doc.get("passes", []):
            if not 0 <= i < j <= n_cmd:
                problems.append(f"pass {[i, j]} is not a range of states")
                pass_dev.append(np.inf)
                covered.append([])
                continue
            Ep = E[i:j]
            d, s = crack.closest(Ep)
            dev = float(d.max())
            for c in np.argsort(-d.max(axis=1))[:refine_top]:
                k = int(np.argmax(d[c]))
                dev = max(
                    dev,
                    _refine_extreme(
                        fl, i + int(c), frac, k, lambda Q: crack.distance(Q[:, 4]), 1.0
                    ),
                )
            pass_dev.append(dev)
            # the sampled path of the pass in time order (the shared end samples repeat)
            ds, ss = d.reshape(-1), s.reshape(-1)
            covered.append(_swept_arcs(ss, ds <= tol + 1e-9, crack.length))
    return TraceReplay(
        problems=problems,
        states_ticks=states,
        pass_max_deviation=pass_dev,
        min_tip_clearance=tip_min,
        min_body_clearance=body_min,
        min_body_clearance_lower_bound=body_lb,
        min_self_distance=self_min,
        covered=covered,
        crack=crack,
    )
