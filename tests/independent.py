"""An independent implementation of SPEC sections 1-3 for checking armpath's results.

Written from the SPEC text only (rotation-matrix formulas, the workpiece description) and sharing
no code with armpath: forward kinematics, the workpiece's inside test and a brute-force
distance to its surface, and replay of command sequences with dense sampling of the motion.
"""

from __future__ import annotations

import numpy as np
import shapely

AB, BC, CD, DE = 140.0, 255.0, 255.0, 65.0
LIMITS_DEG = {1: 125.0, 2: 138.0, 4: 133.5}  # 0-based joint index -> symmetric limit


def rz(t: np.ndarray) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    z, o = np.zeros_like(t), np.ones_like(t)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def rx(t: np.ndarray) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    z, o = np.zeros_like(t), np.ones_like(t)
    return np.stack(
        [np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2
    )


def points(theta_deg: np.ndarray) -> np.ndarray:
    """Points A, B, C, D, E (..., 5, 3) in mm for joint angles in degrees (SPEC section 1)."""
    t = np.radians(np.asarray(theta_deg, dtype=float))
    ez = np.array([0.0, 0.0, 1.0])
    R2 = rz(t[..., 0]) @ rx(t[..., 1])
    R3 = R2 @ rx(t[..., 2])
    R5 = R3 @ rz(t[..., 3]) @ rx(t[..., 4])
    A = np.zeros((*t.shape[:-1], 3))
    B = A + np.array([0.0, 0.0, AB])
    C = B + BC * (R2 @ ez)
    D = C + CD * (R3 @ ez)
    E = D + DE * (R5 @ ez)
    return np.stack([A, B, C, D, E], axis=-2)


class Workpiece:
    """Hollow truncated cone of SPEC section 3: open top, closed bottom plate of wall thickness."""

    def __init__(self, wall_thickness: str = "normal") -> None:
        self.center = np.array([210.0, 0.0])
        self.h, self.rb, self.rt, self.w = 180.0, 168.0, 96.0, 8.0
        slope = (self.rb - self.rt) / self.h
        self.dw = self.w * np.sqrt(1 + slope**2) if wall_thickness == "normal" else self.w
        r_out = lambda z: self.rb - slope * z  # noqa: E731
        self.r_out = r_out
        r_in = lambda z: r_out(z) - self.dw  # noqa: E731
        self.r_in = r_in
        w = self.w
        self.boundary = np.array(
            [(0, 0), (self.rb, 0), (self.rt, self.h), (r_in(self.h), self.h), (r_in(w), w), (0, w)]
        )
        # the surface in the (r, z) half plane as a line (the axis segment is not surface)
        self.outline = shapely.LineString(self.boundary)

    def inside(self, p: np.ndarray) -> np.ndarray:
        r = np.hypot(p[..., 0] - self.center[0], p[..., 1] - self.center[1])
        z = p[..., 2]
        in_z = (z >= 0) & (z <= self.h)
        in_outer = r <= self.r_out(z)
        return in_z & in_outer & ((z <= self.w) | (r >= self.r_in(z)))

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Signed distance for points (N, 3): shapely's distance in the (r, z) half plane."""
        p = np.asarray(p, dtype=float).reshape(-1, 3)
        r = np.hypot(p[:, 0] - self.center[0], p[:, 1] - self.center[1])
        out = shapely.distance(shapely.points(r, p[:, 2]), self.outline)
        return np.where(self.inside(p), -out, out)


def replay(initial_deg, commands) -> np.ndarray:
    """Joint states in degrees after each command, computed in integer ticks."""
    start = np.rint(np.asarray(initial_deg, dtype=float) * 10).astype(int)
    cmds = np.asarray(commands, dtype=int).reshape(-1, 6)
    return np.vstack([start, start + np.cumsum(cmds, axis=0)]) / 10.0


def motion_points(initial_deg, commands, substeps: int) -> np.ndarray:
    """Points A..E along the continuous motion (synchronous linear interpolation)."""
    states = replay(initial_deg, commands)
    cmds = np.diff(states, axis=0)
    s = np.arange(substeps) / substeps
    inner = states[:-1, None, :] + s[None, :, None] * cmds[:, None, :]
    path = np.vstack([inner.reshape(-1, 6), states[-1:]])
    return points(path)


def link_samples(pts: np.ndarray, spacing: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Points sampled along links BC, CD, DE for every configuration, and a tool-tip mask.

    The tool tip is the last 5 mm of DE.
    """
    out, tip = [], []
    for i, j in ((1, 2), (2, 3), (3, 4)):
        a, b = pts[:, i], pts[:, j]
        length = np.linalg.norm(b[0] - a[0])
        s = np.linspace(0, 1, int(np.ceil(length / spacing)) + 1)
        out.append(a[:, None] + s[None, :, None] * (b - a)[:, None])
        tip.append(np.broadcast_to((j == 4) & (s * length > length - 5.0), (len(a), len(s))))
    return np.concatenate(out, axis=1), np.concatenate(tip, axis=1)


def lattice_has_state_within(target, start_deg, n_commands, tol) -> bool:
    """Exhaustively decide whether some lattice state within ``n_commands`` of the start (joint 6
    fixed, limits respected) puts the fingertip within ``tol`` of ``target``.

    Joints 2, 3 are pruned by the wrist-distance condition | |D - T| - DE | <= tol (over all turns
    of joint 1); joints 4, 5 are enumerated completely; joint 1 is taken at the lattice values
    nearest the ideal turn. Only meant for small command counts.
    """
    T = np.asarray(target, float)
    s = np.rint(np.asarray(start_deg, float) * 10).astype(int)
    lim = np.array([10**9, 1250, 1380, 10**9, 1335])
    span = np.arange(-20 * n_commands, 20 * n_commands + 1)

    def values(j):
        v = s[j] + span
        return v[np.abs(v) <= lim[j]]

    q2, q3 = (a.ravel() for a in np.meshgrid(values(1), values(2), indexing="ij"))
    t2, t3 = np.radians(q2 / 10), np.radians(q3 / 10)
    # arm plane at theta1 = 0 is the y-z plane: D = (0, y, z)
    yD = -BC * np.sin(t2) - CD * np.sin(t2 + t3)
    zD = AB + BC * np.cos(t2) + CD * np.cos(t2 + t3)
    rhoT = np.hypot(T[0], T[1])
    dmin = np.hypot(np.abs(yD) - rhoT, zD - T[2])
    dmax = np.hypot(np.abs(yD) + rhoT, zD - T[2])
    keep = (dmin <= DE + tol) & (dmax >= DE - tol)
    phi, yD, zD = (t2 + t3)[keep], yD[keep], zD[keep]
    q4, q5 = (a.ravel() for a in np.meshgrid(values(3), values(4), indexing="ij"))
    t4, t5 = np.radians(q4 / 10), np.radians(q5 / 10)
    u = np.stack([np.sin(t4) * np.sin(t5), -np.cos(t4) * np.sin(t5), np.cos(t5)], -1)  # Rz Rx ez
    for k in range(0, phi.size, 64):
        c, sn = np.cos(phi[k : k + 64, None]), np.sin(phi[k : k + 64, None])
        ex = DE * u[None, :, 0]
        ey = yD[k : k + 64, None] + DE * (c * u[None, :, 1] - sn * u[None, :, 2])
        ez = zD[k : k + 64, None] + DE * (sn * u[None, :, 1] + c * u[None, :, 2])
        ideal = np.degrees(np.arctan2(T[1], T[0]) - np.arctan2(ey, ex)) * 10
        for off in (-1, 0, 1):
            q1 = np.rint(ideal).astype(int) + off
            q1 = q1 + 3600 * np.rint((s[0] - q1) / 3600).astype(int)
            a = np.radians(q1 / 10)
            x = ex * np.cos(a) - ey * np.sin(a)
            y = ex * np.sin(a) + ey * np.cos(a)
            err = np.sqrt((x - T[0]) ** 2 + (y - T[1]) ** 2 + (ez - T[2]) ** 2)
            if np.any((err <= tol) & (np.abs(q1 - s[0]) <= 20 * n_commands)):
                return True
    return False
