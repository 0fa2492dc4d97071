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
from armpath.geometry.primitives import Box, Capsule, cone_frustum
from armpath.model.seed_arm import seed_arm
from armpath.results import load_result
from armpath.scenes import seed_scene
from armpath.viewer.app import HEADLESS_CHROMIUM_ARGS, ArmViewer, free_port, replay_html
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
    bad = _cli("view", "--export-html", str(tmp_path / "x.html"))
    assert bad.returncode == 1 and "needs --result" in bad.stderr
    bad = _cli("animate", str(tmp_path / "missing.json"))
    assert bad.returncode == 1 and bad.stderr.startswith("error: cannot read result file")
    assert not (tmp_path / "x.html").exists()


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
    """Open the viewer as a user would: drag the first joint's slider with the mouse, read the
    fingertip readout, step the replay, and take a screenshot."""
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
                timeout=15000,
            )
            assert np.allclose(_readout_tip(page.inner_text("body")), expected, atol=0.006)
            # Step the replay of reach.json three commands forward.
            result = load_result(out / "reach.json")
            for _ in range(3):
                page.get_by_role("button", name="step ▶").click()
            deg = result.sequence.states()[3] / 10.0
            expected = independent.points(deg)[-1]
            page.wait_for_function(
                "t => document.body.innerText.includes(t)",
                arg=f"x = {expected[0]:.2f}",
                timeout=15000,
            )
            assert np.allclose(_readout_tip(page.inner_text("body")), expected, atol=0.006)
            shot = tmp_path / "viewer.png"
            page.screenshot(path=str(shot))
            # The exported replay plays offline from the file alone.
            html = tmp_path / "replay.html"
            html.write_text(replay_html(result, fps=10.0, max_frames=64))
            offline = browser.new_page(viewport={"width": 1280, "height": 800})
            offline.goto(html.as_uri())
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
