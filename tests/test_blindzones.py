"""Blind zones of the seed arm, checked by an independent optimizer on the SPEC kinematics."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import ndimage
from scipy.optimize import minimize

import independent
from armpath.errors import InvalidInputError
from armpath.model import seed_arm
from armpath.scenes import seed_scene
from armpath.workspace.blindzones import arm_plane_map, meridian_map, surface_blindness

ARMPATH = [sys.executable, "-m", "armpath"]
LIMITS_DEG = ((-125.0, 125.0), (-138.0, 138.0), (-133.5, 133.5))  # joints 2, 3, 5 (SPEC)


def _closest_in_plane(target_yz: np.ndarray, starts: int = 24) -> float:
    """Smallest distance from the fingertip to a point of the arm plane over joints 2, 3, 5
    within their limits (SPEC kinematics of tests/independent.py, multi-start L-BFGS-B)."""
    rng = np.random.default_rng(0)

    def dist(t):
        e = independent.points(np.array([0.0, t[0], t[1], 0.0, t[2], 0.0]))[4]
        return float(np.hypot(e[1] - target_yz[0], e[2] - target_yz[1]) + abs(e[0]))

    best = np.inf
    for _ in range(starts):
        x0 = [rng.uniform(lo, hi) for lo, hi in LIMITS_DEG]
        r = minimize(dist, x0, method="L-BFGS-B", bounds=LIMITS_DEG)
        best = min(best, r.fun)
    return best


@pytest.fixture(scope="module")
def plane():
    return arm_plane_map(seed_arm(), 5.0, 1_500_000, seed=3)


@pytest.mark.slow
def test_central_blind_zone_is_unreachable_and_its_surroundings_reachable(plane):
    """Pixels deep inside the blind zone are at least a few mm from every fingertip position an
    independent optimizer finds; reachable pixels deep inside the reach have a fingertip within
    the pixel."""
    blind = plane.blind
    i, j = plane.at(0.0, 140.0)  # the shoulder B
    assert blind[i, j]
    assert 30_000 < plane.blind_area < 60_000  # mm^2: a disc of radius ~115 mm around B
    deep_blind = ndimage.binary_erosion(blind, iterations=2)
    deep_reach = ndimage.binary_erosion(plane.reach, iterations=3)
    u, v = plane.centers()
    rng = np.random.default_rng(1)
    for mask, inside in ((deep_blind, False), (deep_reach, True)):
        idx = np.argwhere(mask)
        for a, b in idx[rng.choice(len(idx), 8, replace=False)]:
            d = _closest_in_plane(np.array([u[a], v[b]]))
            if inside:
                assert d < plane.pixel, (u[a], v[b], d)
            else:
                assert d > 5.0, (u[a], v[b], d)


def test_three_d_blind_zone_lies_inside_the_plane_one(plane):
    """Twisting the wrist (joint 4) only adds reach: every 3-D blind pixel (rho, z) two pixels
    inside the blind zone (sampling blurs its edge) is unreachable in the arm plane at
    (+-rho, z)."""
    meridian = meridian_map(seed_arm(), 5.0, 2_000_000, seed=4)
    assert np.array_equal(meridian.reach, meridian.reach[::-1])  # mirrored
    blind3 = np.argwhere(ndimage.binary_erosion(meridian.blind, iterations=2))
    assert len(blind3) > 500
    u, v = meridian.centers()
    bad = 0
    for a, b in blind3:
        for sign in (1.0, -1.0):
            i, j = plane.at(sign * u[a], v[b])
            bad += bool(plane.reach[i, j])
    assert bad == 0
    assert 0.0 < meridian.revolved_blind_volume() < 4.0 / 3.0 * np.pi * 130.0**3


def test_face_blindness_integrates_the_cone_area():
    scene = seed_scene()
    wp = scene.workpieces[0]
    (face,) = surface_blindness(seed_arm(), scene.world, wp, 2, faces=("inner",))
    # midpoint circles integrate a linear radius exactly: the lateral area of the inner face
    prof = wp.profile
    (r_top, z_top), (r_bot, z_bot) = prof[3], prof[4]
    slant = np.hypot(r_bot - r_top, z_top - z_bot)
    assert face.area_mm2 == pytest.approx(np.pi * (r_top + r_bot) * slant, rel=1e-6)
    assert np.all((face.blind_mm >= 0) & (face.blind_mm <= face.length_mm))
    assert 0.0 < face.blind_fraction < 0.5
    for blind, reasons in zip(face.blind_mm, face.reasons, strict=True):
        assert (blind > 0) == (len(reasons) > 0)


def test_cli_blindzones_writes_maps(tmp_path):
    out = tmp_path / "bz"
    proc = subprocess.run(
        [*ARMPATH, "blindzones", "--bands", "0", "--samples", "300000", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert "mm^2" in proc.stdout and "mm^3" in proc.stdout
    data = np.load(out / "blindzones.npz")
    assert data["plane_blind"].sum() > 0 and float(data["pixel_mm"]) == 5.0
    assert (out / "blind_maps.png").stat().st_size > 10_000
    bad = subprocess.run(
        [*ARMPATH, "blindzones", "--pixel", "-1", "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bad.returncode == 1 and bad.stderr.strip().startswith("error: pixel size")
    assert not (tmp_path / "x").exists()


# --- bounds on the work (issue 17, item 4) ----------------------------------------------------


def test_map_size_is_known_before_sampling():
    """A map spans the reach BC + CD + DE from the shoulder with a pixel of margin on every
    side: ceil((2 reach + 2 pixel) / pixel) pixels along each axis, computed here from the seed
    geometry; map_shape gives it without sampling and the sampled map has it."""
    from armpath.model.seed_arm import seed_geometry_of
    from armpath.workspace.blindzones import map_shape

    arm = seed_arm()
    g = seed_geometry_of(arm)
    reach = g.bc_mm + g.cd_mm + g.de_mm
    for pixel in (7.0, 20.0):
        side = int(np.ceil((2 * reach + 2 * pixel) / pixel))
        assert map_shape(arm, pixel) == (side, side)
        assert arm_plane_map(arm, pixel, 1000).reach.shape == (side, side)
    with pytest.raises(InvalidInputError, match=r"pixels of a 0\.001 mm map.*change --pixel"):
        map_shape(arm, 0.001, "--pixel")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"pixel": 0.05}, "pixels of a 0.05 mm map"),
        ({"samples": 200_000_001}, "joint samples of a map"),
        ({"chunk": 0}, "chunk must be >= 1"),  # it used to loop forever
        ({"chunk": 4_000_001}, "samples a chunk"),
        ({"seed": -1}, "random seed"),
    ],
)
def test_map_sizes_are_refused_before_any_work(kwargs, message):
    args = {"pixel": 5.0, "samples": 1000, **kwargs}
    with pytest.raises(InvalidInputError, match=message):
        arm_plane_map(seed_arm(), args.pop("pixel"), args.pop("samples"), **args)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"bands": 101}, "circles a face.*100"),
        ({"bands": 0}, "bands must be >= 1"),
        ({"resolution_mm": 1e-20}, "resolution must be at least"),  # bisection below float ulp
        ({"resolution_mm": float("nan")}, "resolution"),
        ({"scan_step_mm": 1e-5, "resolution_mm": 1e-6}, "scan points of a circle"),
        ({"faces": ("top",)}, "face must be one of"),
    ],
)
def test_face_survey_sizes_are_refused_before_any_scan(kwargs, message):
    scene = seed_scene()
    args = {"bands": 2, **kwargs}
    with pytest.raises(InvalidInputError, match=message):
        surface_blindness(seed_arm(), scene.world, scene.workpieces[0], args.pop("bands"), **args)


def test_time_limit_ends_the_maps():
    import time

    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    with time_limit(0.01), pytest.raises(TimeLimitError, match="sampling the meridian map"):
        time.sleep(0.02)
        meridian_map(seed_arm(), 5.0, 1_000_000)
    scene = seed_scene()
    with time_limit(0.01), pytest.raises(TimeLimitError, match="scanning the outer face"):
        time.sleep(0.02)
        surface_blindness(seed_arm(), scene.world, scene.workpieces[0], 3)


def test_a_fine_map_is_drawn_in_blocks_that_keep_a_blind_pixel(monkeypatch):
    """A map finer than 2000 pixels a side is drawn in blocks showing their highest level (50
    million pixels drawn whole took 2 GB): a lone blind pixel stays red, a reachable block
    blue, and the drawn image covers the same extent."""
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure

    from armpath.viz import workspace_figures as wf

    monkeypatch.setattr(wf, "_MOST_DRAWN_PIXELS", 4)
    levels = np.zeros((10, 7), dtype=np.uint8)
    levels[9, 6] = 2  # the last pixel: its block is padded
    levels[0:3, 0:3] = 1
    ax = Figure().add_subplot()
    wf._draw_levels(ax, levels, (0.0, 10.0, 0.0, 7.0), ListedColormap(["w", "b", "r"]))
    (im,) = ax.get_images()
    drawn = np.asarray(im.get_array()).T  # drawn[u, v], blocks of 3 x 3
    assert drawn.shape == (4, 3)
    assert drawn[3, 2] == 2 and drawn[0, 0] == 1 and drawn.sum() == 3
    assert tuple(im.get_extent()) == (0.0, 10.0, 0.0, 7.0)


def test_too_few_samples_for_the_pixels_are_named_not_taken_as_blind(plane, tmp_path):
    """With too few samples for its pixels a map's reachable set has unfilled pixels, and the
    enclosed ones counted as blind: 20,000 samples at 10 mm gave about twice the central blind
    zone, silently. The blind area of the first half of the samples is kept: a map whose
    blind area changes by more than 5 % (or 4 pixels), or whose reachable area grows by more
    than 5 %, over the second half is not settled.
    The dense map (1,500,000 samples at 5 mm) is settled; the sparse ones are not (the arm
    plane's blind area more than 1.5 times the dense one's), and blindzones says so."""
    assert plane.settled and plane.half_blind_area is not None
    sparse = arm_plane_map(seed_arm(), 10.0, 20_000, seed=3)
    assert not sparse.settled and sparse.blind_area > 1.5 * plane.blind_area
    assert not meridian_map(seed_arm(), 20.0, 4_000, seed=3).settled

    def warned(*options: str) -> str:
        r = subprocess.run(
            [*ARMPATH, "blindzones", *options, "--bands", "0"],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            timeout=600,
        )
        assert r.returncode == 0, r.stderr
        return " ".join(r.stderr.split())

    said = warned("--samples", "20000", "--pixel", "10")
    assert "the arm-plane map's reachable area went from" in said
    assert "too few samples for 10 mm pixels" in said
    # one sample: no blind zone, since almost nothing is reachable; its reachable area grew
    # from nothing over the second half (the blind areas alike, 0 and 0, said nothing)
    one = arm_plane_map(seed_arm(), 5.0, 1, seed=3)
    assert one.half_reach_area == 0.0 and one.reach_area > 0.0 and not one.settled
    said = warned("--samples", "1")
    assert "warning: over the second half of its 1 sample the arm-plane map's" in said
    assert "samples the meridian map's reachable area went from" in said
