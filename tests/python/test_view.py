"""The 3D view as a person sees it: served to headless Chromium (Debian's package), screenshotted.

Parts are told apart by hue (the view gives robot, table and object distinct colours); an empty
viser scene is the reference with none of them. Playwright drives Debian's /usr/bin/chromium
(it must not download a browser); WebGL runs in software (SwiftShader).
"""

import dataclasses
import io
import json
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from matplotlib.colors import rgb_to_hsv
from PIL import Image
from playwright.sync_api import sync_playwright
from typer.testing import CliRunner

from handmade_plan import build_plan
from slideplan.cli import app
from slideplan import PlannerConfig, load_object, load_scene, plan
from slideplan.transforms import move_planar, row_to_pose
from slideplan.outputs.view3d import OBJECT_COLOR, ROBOT_COLOR, TABLE_COLOR, _server, object_motions, open_view, record

CHROMIUM = "/usr/bin/chromium"
VIEWPORT = {"width": 800, "height": 600}
DRAWN_PIXELS = 1500  # a part covering fewer pixels than this is not "drawn" in an 800 x 600 view
HUE_TOLERANCE = 12 / 360  # shading changes brightness and saturation, hardly hue
RENDER_TIMEOUT_S = 45.0  # software WebGL on a loaded 2-core machine


def hue_mask(image: np.ndarray, color) -> np.ndarray:
    """Pixels whose hue is that of ``color`` (saturated ones only: the grid and the background are grey)."""
    hsv = rgb_to_hsv(image[..., :3] / 255.0)
    target = rgb_to_hsv(np.array(color) / 255.0)[0]
    distance = np.abs(hsv[..., 0] - target)
    distance = np.minimum(distance, 1.0 - distance)
    return (distance < HUE_TOLERANCE) & (hsv[..., 1] > 0.3) & (hsv[..., 2] > 0.15)


def screenshot(page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(float)


def wait_for(page, condition, timeout=RENDER_TIMEOUT_S):
    """Screenshot until ``condition(image)`` holds; return the last image."""
    deadline = time.monotonic() + timeout
    while True:
        image = screenshot(page)
        if condition(image) or time.monotonic() > deadline:
            return image
        page.wait_for_timeout(250)


def served(result):
    """Serve a plan's view without the environment map: prefiltering it takes SwiftShader about 5 s
    a page, and it only changes the lighting, not what is drawn."""
    view = open_view(result, port=0)
    view.server.scene.configure_environment_map(hdri=None)
    return view


def visit(page, url: str) -> None:
    """Open the view; hide viser's toasts (e.g. "software WebGL rendering"): they are not the view."""
    page.goto(url)
    page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")


def centroid(mask: np.ndarray) -> np.ndarray:
    rows, columns = np.nonzero(mask)
    return np.array([columns.mean(), rows.mean()])


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(
            executable_path=CHROMIUM, headless=True,
            args=["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
        )
        yield chromium
        chromium.close()


@pytest.fixture
def page(browser):
    page = browser.new_page(viewport=VIEWPORT)
    yield page
    page.close()


def test_view_draws_robot_and_table_and_scrubbing_moves_the_object(planned, page):
    empty = _server("127.0.0.1", 0)
    try:
        visit(page, f"http://127.0.0.1:{empty.get_port()}")
        page.wait_for_timeout(2000)  # the empty scene has nothing to wait for
        reference = screenshot(page)
    finally:
        empty.stop()
    for color in (ROBOT_COLOR, TABLE_COLOR, OBJECT_COLOR):
        assert hue_mask(reference, color).sum() < 50, color

    view = served(planned)
    try:
        visit(page, view.url)
        start = wait_for(page, lambda image: all(hue_mask(image, c).sum() > DRAWN_PIXELS for c in (ROBOT_COLOR, TABLE_COLOR)))
        assert hue_mask(start, ROBOT_COLOR).sum() > DRAWN_PIXELS
        assert hue_mask(start, TABLE_COLOR).sum() > DRAWN_PIXELS
        # The arm stands over the object while it slides; hide it as a user would, by its checkbox.
        page.get_by_role("checkbox", name="show arm").uncheck()
        start = wait_for(page, lambda image: hue_mask(image, ROBOT_COLOR).sum() < 50 and hue_mask(image, OBJECT_COLOR).sum() > 100)
        assert hue_mask(start, ROBOT_COLOR).sum() < 50
        object_start = hue_mask(start, OBJECT_COLOR)
        assert object_start.sum() > 100
        # scrub as a user would: focus the time slider and jump to its end
        slider = page.get_by_role("slider")
        slider.focus()
        slider.press("End")
        # Drawn and moved: a frame caught while the object is being redrawn has a few stray pixels.
        end = wait_for(page, lambda image: hue_mask(image, OBJECT_COLOR).sum() > 100
                       and np.linalg.norm(centroid(hue_mask(image, OBJECT_COLOR)) - centroid(object_start)) > 10)
        assert view.slider.value == view.slider.max  # the browser's slider moved the server's timeline
        object_end = hue_mask(end, OBJECT_COLOR)
        assert object_end.sum() > 100
        assert np.linalg.norm(centroid(object_end) - centroid(object_start)) > 10  # pixels
    finally:
        view.server.stop()


def project(camera, points: np.ndarray) -> np.ndarray:
    """Normalised image coordinates (-1..1 across the view) of world points, from the camera state the
    browser reports (position, look-at point, up direction, vertical field of view, aspect)."""
    forward = np.asarray(camera.look_at) - np.asarray(camera.position)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera.up_direction)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    offsets = points - np.asarray(camera.position)
    depth = offsets @ forward
    assert (depth > 0).all()
    half_height = np.tan(camera.fov / 2)
    return np.column_stack([offsets @ right / (depth * half_height * camera.aspect), offsets @ up / (depth * half_height)])


@pytest.mark.parametrize("table, pose", [("square", (0.55, -0.08, 0.4)), ("long", (0.47, 0.25, 0.4))])
def test_the_default_view_frames_the_table_and_the_object_at_its_start_and_end(table, pose, page):
    scene = load_scene(table)
    obj = load_object("crescent", table_height=scene.table.height, pose=pose)
    result = plan(scene, obj, PlannerConfig(seed=1, time_limit_s=20))
    assert result.solved
    view = served(result)
    try:
        visit(page, view.url)
        page.get_by_role("checkbox", name="show arm").uncheck()  # the arm may cover the table, not widen it
        image = wait_for(page, lambda image: hue_mask(image, TABLE_COLOR).sum() > DRAWN_PIXELS
                         and hue_mask(image, OBJECT_COLOR).sum() > 100 and hue_mask(image, ROBOT_COLOR).sum() < 50)
        table_pixels = hue_mask(image, TABLE_COLOR)
        assert table_pixels.sum() > DRAWN_PIXELS and hue_mask(image, OBJECT_COLOR).sum() > 100
        # Nothing of the table is cut off by the window's edge...
        assert not np.concatenate([table_pixels[0], table_pixels[-1], table_pixels[:, 0], table_pixels[:, -1]]).any()
        # ...and the camera the browser uses has every corner, the object at both ends and the grasp inside.
        (client,) = view.server.get_clients().values()
        height = scene.table.height
        polygon = np.asarray(result.table["polygon"])
        start = np.asarray(result.object["points"])
        final = np.column_stack([move_planar(start[:, :2], object_motions(result)[-1]), start[:, 2]])
        grasp = row_to_pose(result.grasp["pose"])[:3, 3]
        inside = np.vstack([np.column_stack([polygon, np.full(len(polygon), height)]), start, final, grasp])
        assert (np.abs(project(client.camera, inside)) < 1.0).all()
    finally:
        view.server.stop()


def test_view_of_an_unsolved_plan_shows_the_scene_and_says_not_solved(planned, page):
    unsolved = dataclasses.replace(
        planned, status="timeout", timing=None, trajectory=planned.trajectory[:0], fingertip_poses=planned.fingertip_poses[:0],
        start_config=planned.start_config[:0], goal_config=planned.goal_config[:0],
        grasp={"pose": np.zeros(0), "config": np.zeros(0), "approach": planned.grasp["approach"][:0]},
    )
    view = served(unsolved)
    try:
        visit(page, view.url)
        image = wait_for(page, lambda image: hue_mask(image, TABLE_COLOR).sum() > DRAWN_PIXELS)
        assert hue_mask(image, TABLE_COLOR).sum() > DRAWN_PIXELS
        assert page.get_by_text("not solved").count() >= 1
        assert page.get_by_role("slider").count() == 0
    finally:
        view.server.stop()


def test_recording_opens_in_a_browser_without_a_server(page, tmp_path):
    # a short plan (about 2 s): the page replays the whole recording in software rendering
    out = record(build_plan(), tmp_path / "plan.html")
    visit(page, out.as_uri())
    # The page adds the scene's meshes one by one: on a busy machine a frame can show the robot before
    # the table, so wait for both.
    image = wait_for(page, lambda image: hue_mask(image, ROBOT_COLOR).sum() > DRAWN_PIXELS
                     and hue_mask(image, TABLE_COLOR).sum() > DRAWN_PIXELS)
    assert hue_mask(image, ROBOT_COLOR).sum() > DRAWN_PIXELS
    assert hue_mask(image, TABLE_COLOR).sum() > DRAWN_PIXELS


def test_play_advances_the_timeline_until_stopped(planned):
    view = open_view(planned, port=0)
    try:
        started = time.monotonic()
        view.play.value = True
        time.sleep(0.5)
        view.play.value = False
        time.sleep(0.1)  # the player notices within one frame
        elapsed = time.monotonic() - started
        stopped_at = view.slider.value
        # Plan time follows the clock: it advanced, and never ran ahead of the wall time that passed
        # (a loaded machine may deliver fewer frames, so no lower bound beyond "it moved").
        assert 0.0 < stopped_at <= elapsed + 0.05
        time.sleep(0.2)
        assert view.slider.value == stopped_at
    finally:
        view.server.stop()


def test_a_version_1_plan_is_timed_for_the_view(planned):
    old = dataclasses.replace(planned, timing=None)  # as read from a slideplan.plan/1 file
    view = open_view(old, port=0)
    try:
        expected = planned.timing["trajectory"]["time_from_start"][-1] + planned.timing["approach"]["time_from_start"][-1]
        assert view.duration == pytest.approx(expected)  # the default limits give the plan's own timing
        assert [segment.name for segment in view.segments] == ["slide", "approach"]
    finally:
        view.server.stop()


def first_line_of_view(plan_file, *options) -> tuple[str, str]:
    """Start ``slideplan view`` in a process of its own, read the line saying where it serves, stop it:
    (that line, everything it wrote on stderr)."""
    process = subprocess.Popen([sys.executable, "-m", "slideplan.cli", "view", str(plan_file), *options],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
    finally:
        process.terminate()
        _, errors = process.communicate(timeout=10)
    return line, errors


def test_port_in_use_picks_another_and_says_so(planned, tmp_path):
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(planned.to_json())
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        line, errors = first_line_of_view(plan_file, "--port", str(port))
    assert line.startswith("view at http://127.0.0.1:") and f":{port};" not in line, line
    served = int(line.split("http://127.0.0.1:")[1].split(";")[0])
    assert served != port and f"port {port} is in use; using {served}" in errors
    assert "warning" not in errors  # this machine only: nothing to warn about


def test_serving_beyond_this_machine_says_so(planned, tmp_path):
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(planned.to_json())
    line, errors = first_line_of_view(plan_file, "--host", "0.0.0.0", "--port", "0")
    assert line.startswith("view at http://0.0.0.0:"), line
    assert "slideplan: warning: serving on every network interface" in errors and "no password" in errors


def test_view_refuses_a_host_it_cannot_listen_on(planned, tmp_path):
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(planned.to_json())
    result = CliRunner().invoke(app, ["view", str(plan_file), "--host", "192.0.2.1"])  # TEST-NET-1: not this machine
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: --host: cannot listen on '192.0.2.1'"), result.stderr


def test_view_refuses_a_plan_of_unknown_schema(planned, tmp_path):
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps({**planned.to_dict(), "schema": "other/1"}))
    result = CliRunner().invoke(app, ["view", str(plan_file)])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: ") and "schema" in lines[0] and str(plan_file) in lines[0]
