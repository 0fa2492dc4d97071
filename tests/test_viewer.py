"""The viewer: display meshes against closed forms, its readouts against the independent
kinematics and clearance rule, HTML replays, and the page driven in headless Chromium."""

from __future__ import annotations

import base64
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import independent
from armpath.errors import InvalidInputError
from armpath.geometry.primitives import Box, Capsule, HalfSpace, Sphere, cone_frustum
from armpath.geometry.world import CollisionWorld
from armpath.model.catalog import puma560
from armpath.model.seed_arm import seed_arm
from armpath.results import load_result
from armpath.scenes import Scene, scene_from_dict, seed_scene
from armpath.viewer.app import (
    HEADLESS_CHROMIUM_ARGS,
    ArmViewer,
    check_address,
    free_port,
    replay_html,
)
from armpath.viewer.meshes import box_mesh, capsule_mesh, revolve, sphere_mesh

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _volume(vertices, faces):
    """Signed volume of a closed triangle mesh (divergence theorem)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def _area(vertices, faces):
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2.0)


def test_display_meshes_match_their_solids():
    frustum = cone_frustum("f", (10.0, -5.0, 0.0), (0.3, 0.2, 1.0), 60.0, 30.0, 100.0)
    v, f = revolve(frustum.origin, frustum.axis, frustum.profile, n_theta=256)
    exact = np.pi * 100.0 / 3.0 * (60.0**2 + 60.0 * 30.0 + 30.0**2)
    assert abs(_volume(v, f)) == pytest.approx(exact, rel=1e-3)
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    v, f = box_mesh(Box("b", np.array([1.0, 2.0, 3.0]), np.array([10.0, 20.0, 5.0]), rot))
    assert abs(_volume(v, f)) == pytest.approx(20.0 * 40.0 * 10.0, rel=1e-12)
    assert _area(v, f) == pytest.approx(2 * (20 * 40 + 40 * 10 + 20 * 10), rel=1e-12)
    v, f = sphere_mesh(np.zeros(3), 50.0, n=128)
    assert abs(_volume(v, f)) == pytest.approx(4 / 3 * np.pi * 50.0**3, rel=2e-3)
    cap = Capsule("c", np.array([0.0, 0.0, 0.0]), np.array([0.0, 80.0, 0.0]), 10.0)
    v, f = capsule_mesh(cap, n=128)
    assert abs(_volume(v, f)) == pytest.approx(np.pi * 100 * 80 + 4 / 3 * np.pi * 1000, rel=3e-3)


@pytest.fixture(scope="module")
def viewer():
    v = ArmViewer(seed_arm(), seed_scene(), port=free_port())
    yield v
    v.stop()


def test_readouts_follow_the_independent_kinematics_and_clearance_rule(viewer):
    rng = np.random.default_rng(3)
    world, arm = viewer.world, viewer.arm
    flagged = free = 0
    for _ in range(40):
        deg = np.round(rng.uniform(-120, 120, 6), 1)
        state = viewer.set_ticks(np.rint(deg * 10).astype(np.int64))
        assert np.allclose(state.tip_mm, independent.points(deg)[-1], atol=1e-9)
        slack = float(world.slack(arm, np.radians(deg)))
        assert (slack < 0) == bool(state.colliding_parts)
        flagged += slack < 0
        free += slack >= 0
        assert [s.value for s in viewer.sliders] == pytest.approx(deg.tolist(), abs=1e-9)
    assert flagged > 0 and free > 0
    # The forearm folded down through the table: the tool link is flagged.
    deg = np.array([-3.5, 97.4, 108.5, 0.0, 17.9, 0.0])
    assert independent.points(deg)[-1][2] < -100.0
    state = viewer.set_ticks(np.rint(deg * 10).astype(np.int64))
    assert any("DE" in p for p in state.colliding_parts), state


def test_replay_steps_through_the_result_and_exports_html(seed_run, viewer):
    out, _ = seed_run
    result = load_result(out / "reach.json")
    assert np.allclose(result.sequence.states()[-1] / 10.0, result.doc["final_deg"], atol=1e-9)
    assert np.linalg.norm(result.tip_path_mm[-1] - result.targets_mm[0]) <= 0.05
    viewer.load_replay(result)
    for k in (0, 7, result.sequence.n_commands):
        viewer.show_command(k)
        deg = result.sequence.states()[k] / 10.0
        assert np.allclose(viewer.state.tip_mm, independent.points(deg)[-1], atol=1e-9)
        assert viewer.timeline.value == k
    page = replay_html(result, fps=30.0, max_frames=40)
    match = re.search(r'window\.__VISER_EMBED_DATA__="([A-Za-z0-9+/=]+)"', page)
    assert match is not None and "<html" in page
    payload = base64.b64decode(match.group(1))
    # zstd frame of the recording, its uncompressed size in front (8 bytes, little endian).
    assert int.from_bytes(payload[:8], "little") > len(payload) // 4 > 1000


def test_target_input_plans_a_reach_and_play_runs_the_replay(viewer):
    viewer.set_ticks(np.array([0, -900, 0, 0, -900, 0]))
    viewer.target_input.value = (20.0, -200.0, 120.0)
    viewer._on_reach()
    seq = viewer._replay
    assert seq is not None and seq.n_commands == 63  # Task 1's optimum from the initial pose
    assert "63 commands" in viewer.reach_status.content
    viewer.speed.value = 60
    viewer._on_play_button("play")
    deadline = time.time() + 30
    while viewer.timeline.value < seq.n_commands and time.time() < deadline:
        time.sleep(0.05)
    assert viewer.timeline.value == seq.n_commands
    assert np.linalg.norm(viewer.state.tip_mm - [20.0, -200.0, 120.0]) <= 0.05


def test_report_markdown_renders_to_html():
    from armpath.report import summary_html

    page = summary_html("# t\n\n| a | b |\n|---|---:|\n| 1 | 2 |\n\n![f](f.png)\n")
    assert "<table>" in page and '<img src="f.png" alt="f"' in page and "<h1>t</h1>" in page


def _cli(*args, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "armpath", *args], capture_output=True, text=True, timeout=timeout
    )


def test_cli_view_export_and_animate(seed_run, tmp_path):
    out, _ = seed_run
    html = tmp_path / "replay.html"
    proc = _cli("view", "--result", str(out / "spotweld.json"), "--export-html", str(html))
    assert proc.returncode == 0, proc.stderr
    assert html.stat().st_size > 500_000 and "__VISER_EMBED_DATA__" in html.read_text()
    gif = tmp_path / "tw.gif"
    proc = _cli("animate", str(out / "trace.json"), "--out", str(gif), "--frames", "12")
    assert proc.returncode == 0, proc.stderr
    from PIL import Image

    assert Image.open(gif).n_frames == 12
    # without a result: the arm alone at its home pose (issue 18: any arm, standing alone)
    alone = _cli("view", "--model", "ur5", "--export-html", str(tmp_path / "ur5.html"))
    assert alone.returncode == 0, alone.stderr
    assert (tmp_path / "ur5.html").read_text().lstrip().lower().startswith("<!doctype html")
    bad = _cli("view", "--export-html", str(tmp_path / "x.txt"))
    assert bad.returncode == 1 and "must end in .html" in bad.stderr
    bad = _cli("animate", str(tmp_path / "missing.json"))
    assert bad.returncode == 1 and bad.stderr.startswith("error: cannot read result file")
    assert not (tmp_path / "x.txt").exists()


# --- empty and far-away scenes, bad addresses -----------------------------------------------

EMPTY_SCENE = 'name = "empty"\n'
FAR_SCENE = """name = "far"
[[obstacles]]
type = "sphere"
name = "far_ball"
center = [5e8, 0, 0]
radius = 10
[[obstacles]]
type = "box"
name = "huge_wall"
center = [0, 3000, 0]
size = [1e8, 10, 1e8]
"""


def _segment_gap(p, q, r, s, n=2001):
    """Distance of two segments by dense sampling (mm), and its sampling allowance."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    a, b = p + t * (q - p), r + t * (s - r)
    gap = np.linalg.norm(a[:, None] - b[None], axis=-1).min()
    return gap, (np.linalg.norm(q - p) + np.linalg.norm(s - r)) / (n - 1)


def test_viewer_with_an_empty_scene_reads_out_self_clearance():
    empty = scene_from_dict({"name": "empty"})
    viewer = ArmViewer(seed_arm(), empty, port=free_port())
    try:
        rng = np.random.default_rng(8)
        for _ in range(5):
            deg = np.round(rng.uniform(-120, 120, 6), 1)
            state = viewer.set_ticks(np.rint(deg * 10).astype(np.int64))
            A, B, C, D, E = independent.points(deg)
            pairs = {"AB - CD": (A, B, C, D), "AB - DE": (A, B, D, E), "BC - DE": (B, C, D, E)}
            gaps = {k: _segment_gap(*v) for k, v in pairs.items()}
            closest = min(gaps, key=lambda k: gaps[k][0])
            assert state.closest == closest
            assert gaps[closest][0] - gaps[closest][1] <= state.clearance_mm <= gaps[closest][0]
            assert state.colliding_parts == () or state.clearance_mm < 1.0
        assert "Clearance" in viewer.readout.content
    finally:
        viewer.stop()
    # an arm with no self pair in an empty scene: nothing to keep clear of
    one_link = scene_from_dict({"name": "empty", "clearance": {"self_margin_mm": 1.0}})
    viewer = ArmViewer(puma560(), one_link, port=free_port())
    try:
        state = viewer.set_ticks(np.zeros(6, dtype=np.int64))
        assert state.colliding_parts == () and state.clearance_mm > 1.0
        # folded: the forearm comes down onto the trunk; the forearm turns red
        state = viewer.set_ticks(np.array([0, 900, 900, 0, 0, 0]))
        assert state.closest == "L0p - L3b" and state.clearance_mm < 0
        assert "L3b" in state.colliding_parts and "collision" in viewer.readout.content
    finally:
        viewer.stop()


def test_viewer_skips_obstacles_far_outside_the_view_box():
    far = (
        Sphere("far", np.array([1e300, 0.0, 0.0]), 10.0),
        Box("far_box", np.array([0.0, -1e300, 0.0]), np.array([10.0, 10.0, 10.0])),
        HalfSpace("far_plane", np.array([0.0, 0.0, -1e300]), np.array([0.0, 0.0, 1.0])),
        Box("wall", np.array([0.0, 3000.0, 0.0]), np.array([1e7, 5.0, 1e7])),
        Sphere("near", np.array([0.0, 300.0, 300.0]), 50.0),
    )
    scene = Scene("far", "", CollisionWorld(far), None, "<test>")
    with np.errstate(all="raise"):  # no overflow on the way
        viewer = ArmViewer(seed_arm(), scene, port=free_port())
    try:
        notes = " ".join(viewer.notes)
        for name in ("far", "far_box", "far_plane"):
            assert f"obstacle {name!r} is not drawn: it lies outside the view box" in notes
        assert "obstacle 'wall' is drawn cut to the view box (±7150 mm about the base)" in notes
        assert len(viewer.notes) == 4
        with np.errstate(all="raise"):
            state = viewer.set_ticks(np.array([0, -900, 0, 0, -900, 0]))
        _, B, C, D, E = independent.points([0, -90, 0, 0, -90, 0])
        centre = np.array([0.0, 300.0, 300.0])
        nearest = min(_segment_gap(p, q, centre, centre)[0] for p, q in ((B, C), (C, D), (D, E)))
        assert state.closest.endswith("near")
        assert state.clearance_mm == pytest.approx(nearest - 50.0, abs=0.2)
    finally:
        viewer.stop()


@pytest.fixture(scope="module")
def small_reach(tmp_path_factory):
    out = tmp_path_factory.mktemp("small_reach")
    proc = _cli("reach", "300", "250", "300", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out / "reach.json"


@pytest.mark.slow
def test_cli_view_serves_and_exports_empty_and_far_scenes(small_reach, tmp_path):
    import urllib.request

    (tmp_path / "empty.toml").write_text(EMPTY_SCENE)
    (tmp_path / "far.toml").write_text(FAR_SCENE)
    port = free_port()
    scene = str(tmp_path / "empty.toml")
    server = subprocess.Popen(
        [sys.executable, "-m", "armpath", "view", "--scene", scene, "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.time() + 90
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as page:
                    assert page.status == 200
                break
            except OSError:
                assert server.poll() is None, server.communicate()[1]
                assert time.time() < deadline
                time.sleep(0.5)
    finally:
        server.terminate()
        server.communicate(timeout=30)
    for scene in ("empty", "far"):
        html = tmp_path / f"{scene}.html"
        proc = _cli(
            "view",
            "--result",
            str(small_reach),
            "--scene",
            str(tmp_path / f"{scene}.toml"),
            "--export-html",
            str(html),
        )
        assert proc.returncode == 0, proc.stderr
        assert "__VISER_EMBED_DATA__" in html.read_text()
        warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning:")]
        if scene == "far":
            assert warnings == [
                "warning: obstacle 'far_ball' is not drawn: it lies outside the view box "
                "(±7150 mm about the base)",
                "warning: obstacle 'huge_wall' is drawn cut to the view box "
                "(±7150 mm about the base)",
            ]
        else:
            assert warnings == []


@pytest.mark.slow
def test_cli_view_refuses_bad_addresses_at_once(tmp_path):
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        taken = busy.getsockname()[1]
        cases = [
            (["--host", "256.1.1.1"], "is not a valid IPv4 address"),
            (["--host", "bad..name"], "neither an IPv4/IPv6 address nor a host name"),
            (["--host", "192.0.2.1"], "is not available on this machine"),
            (["--port", "0"], "--port must be in 1..65535, got 0"),
            (["--port", "70000"], "--port must be in 1..65535, got 70000"),
            (["--port", str(taken)], f"port {taken} on 127.0.0.1 is in use"),
        ]
        for args, message in cases:
            proc = _cli("view", *args, timeout=60)  # a hang fails here
            assert proc.returncode == 1, (args, proc.stderr)
            lines = proc.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("error: "), (args, proc.stderr)
            assert message in lines[0] and proc.stdout == ""
        with pytest.raises(InvalidInputError, match="in use"):
            check_address("127.0.0.1", taken)
    check_address("127.0.0.1", free_port())
    check_address("localhost", free_port())


# --- in a real browser ---------------------------------------------------------------------


def _scene_pixels(picture: Path) -> tuple[int, int, int]:
    """Pixels of the workpiece (tan), the fingertip path (red) and the links (blue) in the 3-D
    view of a 1280 x 800 screenshot (left of the panel, below the notification)."""
    from PIL import Image

    img = np.asarray(Image.open(picture).convert("RGB"), dtype=int)
    assert img.shape == (800, 1280, 3)
    r, g, b = (img[150:700, :850, k] for k in range(3))
    tan = ((r - b > 35) & (r > 150) & (g > 120) & (r > g)).sum()
    red = ((r > 180) & (g < 130) & (b < 130)).sum()
    return int(tan), int(red), int((b - r > 60).sum())


def _readout_tip(text: str) -> np.ndarray:
    m = re.search(r"x = (-?[\d.]+), y = (-?[\d.]+), z = (-?[\d.]+) mm", text)
    assert m is not None, text
    return np.array([float(g) for g in m.groups()])


@pytest.mark.skipif(
    CHROMIUM is None, reason="needs Debian's chromium (the README test command installs it)"
)
def test_viewer_in_headless_chromium(seed_run, tmp_path):
    """Open the viewer as a user would: read the page's title, drag the first joint's slider
    with the mouse, read the fingertip readout, step the replay, and take a screenshot; the
    exported replay carries the same title."""
    sync_api = pytest.importorskip("playwright.sync_api")
    out, _ = seed_run
    port = free_port()
    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "armpath",
            "view",
            "--result",
            str(out / "reach.json"),
            "--port",
            str(port),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(
                executable_path=CHROMIUM,
                args=list(HEADLESS_CHROMIUM_ARGS),
            )
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            deadline = time.time() + 60
            while True:
                try:
                    page.goto(f"http://127.0.0.1:{port}", timeout=5000)
                    break
                except sync_api.Error:
                    assert time.time() < deadline and server.poll() is None, server.stderr.read()
                    time.sleep(0.5)
            page.wait_for_selector("text=Fingertip", timeout=60000)
            result = load_result(out / "reach.json")
            title = f"armpath - reach: {result.n_commands} commands (reach.json)"
            # Each wait allows 60 s, as for the page itself: with the other test worker busy on
            # both cores, the server's updates reach the page late (a 15 s wait for the title ran
            # out once in a fresh-clone run of the whole suite; alone the test passed).
            page.wait_for_function("t => document.title === t", arg=title, timeout=60000)
            start = _readout_tip(page.inner_text("body"))
            assert np.allclose(start, independent.points([0, -90, 0, 0, -90, 0])[-1], atol=0.01)
            # Drag θ1's thumb to about three quarters of its track.
            slider = page.locator("[role=slider]").first
            thumb = slider.bounding_box()
            track = slider.locator("xpath=..").bounding_box()
            page.mouse.move(thumb["x"] + thumb["width"] / 2, thumb["y"] + thumb["height"] / 2)
            page.mouse.down()
            page.mouse.move(
                track["x"] + 0.75 * track["width"], thumb["y"] + thumb["height"] / 2, steps=12
            )
            page.mouse.up()
            theta1 = float(slider.get_attribute("aria-valuenow"))
            assert 60.0 < theta1 < 120.0 and abs(theta1 * 10 - round(theta1 * 10)) < 1e-9
            expected = independent.points([theta1, -90, 0, 0, -90, 0])[-1]
            page.wait_for_function(
                "t => document.body.innerText.includes(t)",
                arg=f"x = {expected[0]:.2f}",
                timeout=60000,
            )
            assert np.allclose(_readout_tip(page.inner_text("body")), expected, atol=0.006)
            # Step the replay of reach.json three commands forward.
            for _ in range(3):
                page.get_by_role("button", name="step ▶").click()
            deg = result.sequence.states()[3] / 10.0
            expected = independent.points(deg)[-1]
            page.wait_for_function(
                "t => document.body.innerText.includes(t)",
                arg=f"x = {expected[0]:.2f}",
                timeout=60000,
            )
            assert np.allclose(_readout_tip(page.inner_text("body")), expected, atol=0.006)
            shot = tmp_path / "viewer.png"
            page.screenshot(path=str(shot))
            # The exported replay plays offline from the file alone.
            html = tmp_path / "replay.html"
            html.write_text(replay_html(result, fps=10.0, max_frames=64))
            offline = browser.new_page(viewport={"width": 1280, "height": 800})
            offline.goto(html.as_uri())
            assert offline.title() == title
            replay_shot = tmp_path / "replay.png"
            deadline = time.time() + 90  # decoding and software rendering are slow under load
            while True:
                offline.wait_for_timeout(2000)
                offline.screenshot(path=str(replay_shot))
                if _scene_pixels(replay_shot)[0] > 2000 or time.time() > deadline:
                    break
            browser.close()

        for picture in (shot, replay_shot):
            tan, red, blue = _scene_pixels(picture)
            assert tan > 2000 and red > 200 and blue > 300, (picture, tan, red, blue)
    finally:
        server.terminate()
        server.wait(timeout=30)
