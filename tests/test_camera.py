"""The ZED camera: 30 Hz images and CameraInfo as gazebo_ros_camera publishes them, pixels where a pinhole model puts
them, Gazebo's noise, and a one-line error when there is no OpenGL.

Rendering tests are skipped where no headless OpenGL context (EGL or OSMesa) can be made; .ci/run installs Mesa.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

from conftest import Log
from racecar_sim import Simulator
from racecar_sim.core.errors import DescriptionError, RenderingError
from racecar_sim.core.transforms import compose, quat_from_axis_angle, quat_from_rpy, quat_to_matrix
from racecar_sim.description import load_robot
from racecar_sim.description.kinematics import link_pose
from racecar_sim.render.gl import library_present, shared_context
from racecar_sim.sensors.camera import CameraSpec, camera_spec
from racecar_sim.worlds import Spawn
from racecar_sim.worlds.catalog import DATA

IMAGE = "/camera/zed/rgb/image_rect_color"
INFO = "/camera/zed/rgb/camera_info"
WIDTH, HEIGHT = 640, 480
FX = 640 / (2 * math.tan(0.8709216071359963 / 2))  # 687.8066: the file's 2 atan(320 / 687.8065795898438)

try:
    GL = shared_context()
    GL_MISSING = ""
except RenderingError as exc:
    GL, GL_MISSING = None, str(exc)
needs_gl = pytest.mark.skipif(GL is None, reason=GL_MISSING)


def ceil_div(a: int, b: int) -> int:
    return -(-a // b)


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def camera_sim(world: str = "empty", seed: int = 0, noise: bool = True, **kwargs) -> Simulator:
    """A simulator with the camera on and the lidar off (not under test here)."""
    sim = Simulator(world=world, seed=seed, lidar=False, camera=True, sensor_noise=noise, **kwargs)
    assert sim.car.camera is not None, "the camera did not start although a GL context exists"
    return sim


def pixels(msg) -> np.ndarray:
    return np.asarray(msg.data, dtype=np.uint8).reshape(msg.height, msg.width, 3)


# --- the description --------------------------------------------------------------------------------------------


def test_spec_reads_the_sensor_block():
    spec = camera_spec(load_robot())
    assert (spec.image_topic, spec.info_topic, spec.frame_id) == (IMAGE, INFO, "camera_link")
    assert (spec.rate_hz, spec.width, spec.height, spec.encoding, spec.step) == (30.0, 640, 480, "bgr8", 1920)
    assert (spec.near, spec.far, spec.noise_mean, spec.noise_stddev) == (0.02, 300.0, 0.0, 0.007)
    assert spec.focal_length == pytest.approx(687.8066, abs=1e-4) and spec.fx == spec.focal_length
    assert math.degrees(spec.fovy) == pytest.approx(38.47, abs=0.01)  # 2 atan(tan(hfov/2) * 480/640)
    assert (spec.cx, spec.cy, spec.baseline, spec.distortion) == (320.5, 240.5, 0.0, (0.0,) * 5)


def _edited(path: str, text: str | None) -> CameraSpec:
    sensor = copy.deepcopy(load_robot().sensor("camera"))
    parent_path, _, tag = path.rpartition("/")
    parent = sensor.element.find(parent_path) if parent_path else sensor.element
    child = parent.find(tag)
    if text is None:
        parent.remove(child)
    else:
        child.text = text
    return CameraSpec.from_sensor(sensor)


@pytest.mark.parametrize(
    "path, text, message",
    [
        ("camera/horizontal_fov", None, "<horizontal_fov> is missing"),
        ("camera/horizontal_fov", "wide", "'wide' is not a number"),
        ("camera/horizontal_fov", "3.5", "must be in (0, pi)"),
        ("camera/image/width", "640.5", "<image/width> '640.5' is not a whole number"),
        ("camera/image/format", "L8", "'L8' is not one of B8G8R8, R8G8B8"),
        ("camera/clip/far", "0.01", "0 < near < far"),
        ("camera/noise/stddev", "-1", "must not be negative"),
        ("camera/noise/type", "poisson", "'poisson' is not supported"),
    ],
)
def test_a_bad_field_is_named(path, text, message):
    with pytest.raises(DescriptionError, match="zed_camera_left_sensor") as err:
        _edited(path, text)
    assert message in str(err.value)


def test_rgb_format_and_a_sensor_without_plugin():
    assert _edited("camera/image/format", "R8G8B8").encoding == "rgb8"
    bare = _edited("plugin", None)
    assert (bare.image_topic, bare.info_topic, bare.frame_id) == (
        "/zed_camera_left_camera/image_raw",
        "/zed_camera_left_camera/camera_info",
        "camera_link",
    )


# --- the model --------------------------------------------------------------------------------------------------


@needs_gl
def test_the_mujoco_camera_sits_on_camera_link_looking_along_x():
    sim = camera_sim()
    m, d = sim.model, sim.data
    cam, site = m.camera("zed_camera_left_sensor").id, m.site("camera_link").id
    np.testing.assert_allclose(d.cam_xpos[cam], d.site_xpos[site], atol=1e-12)
    cam_axes, link_axes = d.cam_xmat[cam].reshape(3, 3), d.site_xmat[site].reshape(3, 3)
    np.testing.assert_allclose(-cam_axes[:, 2], link_axes[:, 0], atol=1e-9)  # MuJoCo looks along its -z
    np.testing.assert_allclose(cam_axes[:, 1], link_axes[:, 2], atol=1e-9)  # image up = link z
    assert m.cam_fovy[cam] == pytest.approx(38.4714, abs=1e-4)
    assert m.vis.map.znear * m.stat.extent == pytest.approx(0.02, rel=1e-6)
    assert m.vis.map.zfar * m.stat.extent == pytest.approx(300.0, rel=1e-6)
    assert m.vis.global_.offwidth >= WIDTH and m.vis.global_.offheight >= HEIGHT


# --- messages and schedule --------------------------------------------------------------------------------------


@needs_gl
def test_300_images_in_10_s_at_exact_stamps():
    sim = camera_sim(noise=False)
    log = Log(sim, IMAGE, INFO)
    sim.run_until(10.0)
    images, infos = log[IMAGE], log[INFO]
    assert len(images) == len(infos) == 300
    step = sim.step_ns
    expected = [ceil_div(ceil_div(k * 10**9, 30), step) * step for k in range(1, 301)]  # k/30 s, up to a step
    assert [stamp_ns(m) for m in images] == expected == [stamp_ns(m) for m in infos]
    msg = images[-1]
    assert (msg.height, msg.width, msg.encoding, msg.step, msg.is_bigendian) == (480, 640, "bgr8", 1920, 0)
    assert msg.header.frame_id == "camera_link"
    assert msg.data.dtype == np.uint8 and msg.data.shape == (480 * 1920,)
    assert images[0].data is not images[1].data, "each message owns its pixels"


@needs_gl
def test_camera_info_as_gazebo_ros_camera_fills_it():
    sim = camera_sim()
    log = Log(sim, INFO)
    sim.run_until(0.04)
    info = log[INFO][0]
    assert (info.header.frame_id, info.height, info.width, info.distortion_model) == (
        "camera_link",
        480,
        640,
        "plumb_bob",
    )
    np.testing.assert_array_equal(info.d, np.zeros(5))
    np.testing.assert_allclose(info.k, [FX, 0, 320.5, 0, FX, 240.5, 0, 0, 1], rtol=1e-15)
    np.testing.assert_array_equal(info.r, np.eye(3).ravel())
    np.testing.assert_allclose(info.p, [FX, 0, 320.5, 0, 0, FX, 240.5, 0, 0, 0, 1, 0], rtol=1e-15)
    assert info.k[0] == pytest.approx(687.8066, abs=1e-4)


@needs_gl
def test_nothing_is_rendered_while_nobody_listens_and_the_schedule_holds():
    quiet, busy = camera_sim(seed=4), camera_sim(seed=4)
    busy_log = Log(busy, IMAGE)
    quiet.run_until(1.0)
    busy.run_until(1.0)
    assert quiet.car.camera.frames_rendered == 0 and quiet.bus.count(IMAGE) == 0 and quiet.bus.count(INFO) == 0
    assert busy.car.camera.frames_rendered == 30
    quiet_log = Log(quiet, IMAGE)
    quiet.run_until(1.1)
    busy.run_until(1.1)
    assert [stamp_ns(m) for m in quiet_log[IMAGE]] == [stamp_ns(m) for m in busy_log[IMAGE][30:]]
    # noise is keyed by the stamp: frames skipped before change nothing after
    assert all(np.array_equal(a.data, b.data) for a, b in zip(quiet_log[IMAGE], busy_log[IMAGE][30:]))


@needs_gl
def test_a_run_log_overhears_the_camera_and_takes_its_one_frame_at_the_end():
    from racecar_sim.drivers import ConstantCommand
    from racecar_sim.runtime.run_log import RunLog

    quiet, busy = camera_sim(seed=3), camera_sim(seed=3)
    for sim in (quiet, busy):
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)  # the view changes from frame to frame
    quiet_log = RunLog(quiet.bus, None, IMAGE)
    busy_log = Log(busy, IMAGE)
    quiet.run_until(1.0)
    busy.run_until(1.0)
    assert quiet.car.camera.frames_rendered == 0 and quiet.bus.count(IMAGE) == 0  # its log alone wants no frame
    quiet_log.take_frame(quiet.car.camera, quiet.time_ns)
    last = busy_log[IMAGE][-1]  # the frame the camera's last tick (at 1.0 s, the 30th) published
    assert quiet.car.camera.frames_rendered == 1 and stamp_ns(last) == quiet.time_ns
    assert quiet_log.last_image is not None and not np.array_equal(last.data, busy_log[IMAGE][-2].data)
    np.testing.assert_array_equal(pixels(quiet_log.last_image), pixels(last))


@needs_gl
@pytest.mark.parametrize("summary", [True, False])
def test_a_run_with_only_its_summary_to_show_draws_one_frame_at_the_end(tmp_path, monkeypatch, summary):
    """`racecar-sim run --no-record --no-video`: nothing takes the camera's frames while the run goes, the summary's
    inset is drawn once at the end (as the last tick's frame: 1 s is 30 camera periods); with --no-summary, none."""
    from racecar_sim.cli.main import main
    from racecar_sim.runtime.run_log import RunLog

    taken: list[tuple[int, int, object]] = []
    take = RunLog.take_frame

    def spy(self, camera, stamp_ns):
        before = camera.frames_rendered
        take(self, camera, stamp_ns)
        taken.append((before, camera.frames_rendered, self.last_image))

    monkeypatch.setattr(RunLog, "take_frame", spy)
    args = ["run", "--world", "empty", "--duration", "1", "--no-record", "--no-video", "--out", str(tmp_path)]
    assert main(args + ([] if summary else ["--no-summary"])) == 0
    if not summary:
        assert taken == [] and not (tmp_path / "summary.png").exists()
        return
    ((before, after, image),) = taken
    assert (before, after) == (0, 1) and image is not None and stamp_ns(image) == 1_000_000_000
    assert (image.height, image.width) == (HEIGHT, WIDTH) and (tmp_path / "summary.png").is_file()


# --- pixels -----------------------------------------------------------------------------------------------------

PLATES = [(3.0, 0.5, 0.6), (2.0, -0.35, 0.1), (5.0, 0.0, 0.14), (1.5, 0.5, 0.05)]  # x, y, z of plate centres, m
PLATE = 0.12  # m, side of the square red plates, which face the camera (-x) so they project without distortion


def plates_world(folder: Path, yaw: float = 0.0) -> Path:
    """Red square plates on a plain background (no ground, no sun: only the headlight and ambient light), turned
    by `yaw` so that they face a camera turned as much."""
    models = "".join(
        f"<model name='plate{i}'><static>true</static><pose>{x} {y} {z} 0 0 {yaw}</pose><link name='l'>"
        f"<visual name='v'><geometry><box><size>0.001 {PLATE} {PLATE}</size></box></geometry><material>"
        f"<ambient>1 0 0 1</ambient><diffuse>1 0 0 1</diffuse></material></visual></link></model>"
        for i, (x, y, z) in enumerate(PLATES)
    )
    path = folder / "plates.world"
    path.write_text(f"<sdf version='1.6'><world name='plates'>{models}</world></sdf>")
    return path


# The plates world has nothing to stand on, on purpose (a plain background): the car floats, and the spawn check's
# warning about it is expected here (a `.` stands for its colon: a filter's fields are colon-separated).
FLOATS = pytest.mark.filterwarnings(r"ignore:.*/plates\.world. the world has no collision geometry:UserWarning")


def pinhole(point: np.ndarray, spawn_yaw: float = 0.0, spawn=(0.0, 0.0, 0.05)) -> tuple[float, float]:
    """(column, row) of a world point, in pixel-centre coordinates, by an independent pinhole model: the camera
    pose from the URDF's kinematics, fx from the hfov, the optical axis through the image centre."""
    robot = load_robot()
    base = (np.array(spawn, dtype=float), quat_from_axis_angle((0.0, 0.0, 1.0), spawn_yaw))
    sensor = robot.sensor("camera")
    pos, quat = compose(*base, *link_pose(robot, "camera_link"))
    pos, quat = compose(pos, quat, np.array(sensor.pose.xyz), quat_from_rpy(sensor.pose.rpy))
    x, y, z = quat_to_matrix(quat).T @ (point - pos)  # link frame: x forward, y left, z up
    return (WIDTH - 1) / 2 - FX * y / x, (HEIGHT - 1) / 2 - FX * z / x


def red_blobs(image_bgr: np.ndarray) -> list[tuple[float, float]]:
    """Centroids (column, row) of the red regions, left to right."""
    b, g, r = (image_bgr[..., i].astype(int) for i in range(3))
    mask = (r > 100) & (g < 40) & (b < 40)
    cols = np.flatnonzero(mask.any(axis=0))
    groups = np.split(cols, np.flatnonzero(np.diff(cols) > 1) + 1)
    centroids = []
    for group in groups:
        rows, columns = np.nonzero(mask[:, group[0] : group[-1] + 1])
        centroids.append((float(columns.mean() + group[0]), float(rows.mean())))
    return centroids


@needs_gl
@FLOATS
def test_red_plates_land_where_a_pinhole_model_puts_them(tmp_path):
    sim = camera_sim(world=str(plates_world(tmp_path)), noise=False)
    image = sim.car.camera.capture(0)
    assert image.shape == (HEIGHT, WIDTH, 3)
    expected = sorted(pinhole(np.array(p)) for p in PLATES)
    found = red_blobs(image)
    assert len(found) == len(PLATES)
    for (u, v), (eu, ev) in zip(found, expected):
        assert abs(u - eu) < 1.0 and abs(v - ev) < 1.0, f"blob at ({u:.2f}, {v:.2f}), pinhole says ({eu:.2f}, {ev:.2f})"
    # and its apparent size is the pinhole's too: the nearest plate, edge to edge along its middle row
    x, y, z = min(PLATES)
    left, right = pinhole(np.array([x, y + PLATE / 2, z])), pinhole(np.array([x, y - PLATE / 2, z]))
    blue, green, red = (image[..., i].astype(int) for i in range(3))
    columns = np.flatnonzero(((red > 100) & (green < 40) & (blue < 40))[round(left[1])])
    assert columns.size == pytest.approx(right[0] - left[0], abs=1.5)


@needs_gl
@FLOATS
def test_the_spawn_pose_moves_the_view(tmp_path):
    """Turned 20 degrees left, the car sees every plate 20 degrees further right - as the pinhole model says."""
    yaw = math.radians(20)
    sim = camera_sim(world=str(plates_world(tmp_path, yaw)), noise=False, spawn=Spawn(0.3, -0.2, 0.05, yaw))
    found = red_blobs(sim.car.camera.capture(0))
    expected = sorted(pinhole(np.array(p), yaw, (0.3, -0.2, 0.05)) for p in PLATES)
    expected = [(u, v) for u, v in expected if 0 <= u < WIDTH]
    assert len(found) == len(expected) >= 2
    for (u, v), (eu, ev) in zip(found, expected):
        assert abs(u - eu) < 1.0 and abs(v - ev) < 1.0


@needs_gl
def test_gaussian_noise_as_gazebo_adds_it():
    sim = camera_sim(seed=7)
    camera = sim.car.camera
    camera.noise = False
    clean = camera.capture(1_000_000_000).astype(int)
    camera.noise = True
    noisy = camera.capture(1_000_000_000).astype(int)
    inside = (clean > 10) & (clean < 245)  # away from the clamp
    diff = (noisy - clean)[inside]
    assert diff.std() == pytest.approx(0.007 * 255, rel=0.10)
    assert abs(diff.mean()) < 0.05
    # one sample per pixel, added to every channel (Gazebo's shader adds one value to r, g and b)
    all_inside = inside.all(axis=2)
    d = (noisy - clean)[all_inside]
    assert np.array_equal(d[:, 0], d[:, 1]) and np.array_equal(d[:, 1], d[:, 2])
    assert np.array_equal(noisy, camera.capture(1_000_000_000)), "same stamp, same noise"


@needs_gl
def test_same_seed_same_images_other_seed_other_noise():
    runs = {}
    for name, seed in (("a", 11), ("b", 11), ("c", 12)):
        sim = camera_sim(seed=seed)
        log = Log(sim, IMAGE)
        sim.run_until(0.2)
        runs[name] = [pixels(m).astype(int) for m in log[IMAGE]]
    assert len(runs["a"]) == 6
    assert all(np.array_equal(x, y) for x, y in zip(runs["a"], runs["b"]))
    differences = [x - y for x, y in zip(runs["a"], runs["c"])]
    assert all(d.any() for d in differences)
    assert np.std(differences[-1]) == pytest.approx(math.sqrt(2) * 0.007 * 255, rel=0.15)  # two noises, same scene


@needs_gl
def test_rgb8_is_the_same_image_in_the_other_order():
    sim = camera_sim(noise=False)
    bgr = sim.car.camera.capture(0)
    sim.car.camera.spec = dataclasses.replace(sim.car.camera.spec, encoding="rgb8")
    assert np.array_equal(sim.car.camera.capture(0), bgr[..., ::-1])


# --- what the worlds look like ----------------------------------------------------------------------------------


@needs_gl
def test_sky_is_flat_and_the_ground_shows_its_squares():
    sim = camera_sim(noise=False)
    image = sim.car.camera.capture(0).astype(int)
    sky = image[:100]
    assert np.all(sky == sky[0, 0]) and abs(sky[0, 0, 0] - 0.7 * 255) <= 1  # the world's background, 0.7 grey
    ground = image[300:]
    assert ground.std() > 5, "the ground's checker squares let the camera see motion"
    assert 60 < ground.mean() < 230, "the ground is lit, not black or burnt out"


def test_flat_sky_only_where_painting_it_is_exact():
    """The sky is painted only for a one-colour skybox (MuJoCo's colour, 0-255) and only when nothing drawn is
    translucent (blended over the cleared background, it would differ from blending over the sky)."""
    import mujoco

    from racecar_sim.physics.world_geoms import VISUAL_GROUP
    from racecar_sim.render.offscreen import flat_sky

    def model(sky_top, sky_bottom, alpha=1.0, material_alpha=1.0, skybox=True):
        spec = mujoco.MjSpec()
        spec.add_material(name="paint", rgba=[1, 1, 1, material_alpha])
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=[1, 1, 1], group=VISUAL_GROUP, rgba=[1, 0, 0, alpha], material="paint"
        )
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=[1, 1, 1], group=VISUAL_GROUP + 1, rgba=[1, 0, 0, 0.5]
        )  # not drawn by the camera: may be translucent
        if skybox:
            spec.add_texture(
                name="sky",
                type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
                width=8,
                height=8,
                rgb1=sky_top,
                rgb2=sky_bottom,
            )
        return spec.compile()

    assert flat_sky(model([0.2, 0.4, 0.6], [0.2, 0.4, 0.6])).tolist() == [51, 102, 153]
    assert flat_sky(model([0.2, 0.4, 0.6], [0.6, 0.4, 0.2])) is None, "a gradient sky is drawn by MuJoCo"
    assert flat_sky(model([0.2, 0.4, 0.6], [0.2, 0.4, 0.6], alpha=0.5)) is None
    assert flat_sky(model([0.2, 0.4, 0.6], [0.2, 0.4, 0.6], material_alpha=0.5)) is None
    assert flat_sky(model([0.2, 0.4, 0.6], [0.2, 0.4, 0.6], skybox=False)) is None


@needs_gl
@pytest.mark.parametrize("world", ["walker", "ar"])
def test_the_painted_sky_is_mujocos_skybox_bit_for_bit(world):
    """Frames are drawn without MuJoCo's cube-mapped skybox (slow in software GL) and the pixels left at alpha 0
    are painted its flat colour: from any pose, the image is the one MuJoCo draws with its skybox, noise included."""
    import mujoco

    sim = camera_sim(world=world, seed=2)
    model, data, renderer = sim.model, sim.data, sim.car.camera.renderer
    assert renderer.sky is not None and renderer.sky.tolist() == [178] * 3  # the worlds' 0.7 grey background
    free = model.jnt_qposadr[np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)[0]]
    rng = np.random.default_rng(7)
    start = data.qpos.copy()
    sky_seen = []
    for k in range(6):
        data.qpos[:] = start
        data.qpos[free : free + 2] += rng.uniform(-3.0, 3.0, 2)
        yaw = rng.uniform(-math.pi, math.pi)
        data.qpos[free + 3 : free + 7] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
        mujoco.mj_forward(model, data)
        painted = sim.car.camera.capture(1_000_000 * k)
        sky_seen.append((renderer.target.rgba[..., 3] == 0).mean())
        flat, renderer.target.sky = renderer.target.sky, None  # MuJoCo draws its skybox
        drawn = sim.car.camera.capture(1_000_000 * k)
        renderer.target.sky = flat
        assert np.array_equal(painted, drawn), f"pose {k}: {(painted != drawn).any(axis=2).sum()} pixels differ"
    assert sum(0.05 < f < 0.95 for f in sky_seen) >= 3, f"too few poses see both sky and ground: {sky_seen}"
    sim.close()


@needs_gl
def test_tunnel_walls_are_lit():
    sim = camera_sim(world="tunnel", noise=False)
    image = sim.car.camera.capture(0).astype(int)
    walls = image[:150, :50]  # the wall on the left, in front of the car
    assert walls.mean() > 60


def _tag_bits(image: np.ndarray) -> np.ndarray:
    """The AR tag of the `ar` world, read back as 8 x 8 cells (margin, border, 4 x 4 code): its pose from the
    world file (5 cm square, facing the car at x = 1 m, 2.5 cm above the ground)."""
    grey = image.mean(axis=2)
    bits = np.zeros((8, 8), dtype=bool)
    cell = 0.05 / 8
    for i in range(8):
        for j in range(8):
            point = np.array([1.0 - 0.0005, 0.025 - (j + 0.5) * cell, 0.05 - (i + 0.5) * cell])
            u, v = pinhole(point)
            bits[i, j] = grey[round(v), round(u)] > 128
    return bits


@needs_gl
def test_the_ar_tag_one_metre_ahead_is_readable():
    sim = camera_sim(world="ar", noise=False)
    image = sim.car.camera.capture(0)
    marker = np.asarray(PILImage.open(DATA / "models/ar_tags/marker1/materials/marker1.png").convert("L"))
    n = marker.shape[0] // 8
    expected = marker[n // 2 :: n, n // 2 :: n] > 128
    assert np.array_equal(_tag_bits(image), expected)


@needs_gl
def test_opencv_decodes_the_ar_tag():
    cv2 = pytest.importorskip("cv2")
    if not hasattr(cv2, "aruco"):
        pytest.skip("this OpenCV has no aruco module")
    sim = camera_sim(world="ar")  # with noise
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    _, ids, _ = detector.detectMarkers(sim.car.camera.capture(0))
    assert ids is not None and ids.ravel().tolist() == [1]


# --- no OpenGL --------------------------------------------------------------------------------------------------


def _run_python(code: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    """`code` run in a fresh interpreter whose GL choice comes only from `env`; it must exit 0."""
    parent = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    result = subprocess.run(
        [sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120, env={**parent, **env}
    )
    assert result.returncode == 0, result.stderr
    return result


def _python(code: str, env: dict[str, str]) -> str:
    """stdout of `code` run in a fresh interpreter whose GL choice comes only from `env`."""
    return _run_python(code, env).stdout


def _gl_error(env: dict[str, str]) -> str:
    return _python(
        "from racecar_sim.core.errors import RenderingError\n"
        "from racecar_sim.render.gl import create_context\n"
        "try:\n    create_context()\nexcept RenderingError as exc:\n    print(exc)\nelse:\n    print('OK')\n",
        env,
    )


@pytest.mark.parametrize(
    "env, names",
    [
        # no EGL vendor library: EGL cannot start, as on a box without libegl-mesa0 / libgl1-mesa-dri
        (
            {"MUJOCO_GL": "egl", "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl_vendor.json"},
            ["EGL", "libegl1", "libgl1-mesa-dri"],
        ),
        ({"MUJOCO_GL": "off"}, ["MUJOCO_GL=off", "egl or osmesa"]),
    ],
)
def test_no_gl_is_one_line_naming_the_packages_and_the_switch(env, names):
    out = _gl_error(env)
    assert len(out.strip().splitlines()) == 1, out
    for name in names + ["--no-camera"]:
        assert name in out, out


def test_missing_osmesa_names_its_package():
    if library_present("osmesa"):
        pytest.skip("libOSMesa is installed here")
    out = _gl_error({"MUJOCO_GL": "osmesa"})
    assert len(out.strip().splitlines()) == 1 and "libosmesa6" in out and "--no-camera" in out, out


@pytest.mark.parametrize(
    "env",
    [{"MUJOCO_GL": "osmesa"}, {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl.json"}],
    ids=["chosen", "after-egl-fails"],
)
def test_osmesa_renders_when_chosen_or_when_egl_fails(env):
    """MuJoCo loads its GL functions once per process, EGL's first: a failed EGL try must not spoil OSMesa."""
    if not library_present("osmesa"):
        pytest.skip("libOSMesa is not installed here (.ci/run installs libosmesa6)")
    code = (
        "from racecar_sim import Simulator\n"
        "sim = Simulator(lidar=False, sensor_noise=False)\n"
        "image = sim.car.camera.capture(0)\n"
        "print(sim.car.camera.gl_renderer.split(':')[0], int(image[0, 0, 0]), int(image[-1].mean()))\n"
        "sim.close()\n"
    )
    result = _run_python(code, env)
    out = result.stdout
    backend, sky, ground = out.split()
    assert backend == "osmesa" and abs(int(sky) - 178) <= 1 and 60 < int(ground) < 230, out
    assert "Traceback" not in result.stderr and "Exception ignored" not in result.stderr, result.stderr


@needs_gl
def test_compiled_frame_noise_is_gazebos_noise_from_the_noise_table():
    from racecar_sim.core.rng import NoiseTable
    from racecar_sim.sensors.camera import add_noise

    sim = camera_sim(seed=4)
    camera = sim.car.camera
    camera.noise = False
    clean = camera.capture(2_000_000_000)
    camera.noise = True
    noisy = camera.capture(2_000_000_000)
    unit = NoiseTable.shared("camera", HEIGHT * WIDTH, np.float32).sample(
        camera.seed ^ camera._stream_key, 2_000_000_000
    )
    assert np.array_equal(noisy, add_noise(clean, unit, 0.0, 0.007 * 255))  # numpy's reference, value for value
    assert not np.array_equal(noisy, camera.capture(2_033_333_333 - 1)), "another stamp, other noise"
    sim.close()


def test_render_ahead_publishes_the_same_frames_one_period_later():
    """render_ahead() (the main job's camera): each frame is drawn on the GL thread while the sim goes on and is
    published at the next frame's tick, stamped with its own time; the frames and their stamps are those of the
    synchronous camera, and flush() publishes the last one."""
    runs = {}
    for ahead in (False, True):
        sim = camera_sim("walker", seed=3)
        got: list[tuple[int, int, np.ndarray]] = []
        sim.subscribe(
            sim.car.camera.spec.image_topic,
            lambda msg, sim=sim, got=got: got.append((sim.time_ns, stamp_ns(msg), pixels(msg))),
        )
        sim.car.camera.render_ahead(ahead)
        sim.run_until(0.2)
        sim.car.camera.flush()
        runs[ahead] = got
        sim.close()
    sync, ahead = runs[False], runs[True]
    assert [s for _, s, _ in ahead] == [s for _, s, _ in sync] and len(sync) == 6  # 30 Hz for 0.2 s
    next_ticks = [s for _, s, _ in sync[1:]] + [200_000_000]  # the last goes out by flush(), at the end
    for (t_sync, stamp, frame), (t_ahead, _, frame_ahead), later in zip(sync, ahead, next_ticks):
        assert t_sync == stamp  # published at the time it shows
        assert t_ahead == later  # at the next frame's tick
        np.testing.assert_array_equal(frame_ahead, frame)


def test_a_capture_while_frames_are_drawn_ahead_changes_none_of_them():
    """Two scenes take turns while frames are drawn ahead (the next is drawn while the last is published): a
    capture() in between, even from a subscriber of the frame being published, must not draw over a frame not yet
    taken. The published frames are those of a run without the captures."""
    runs = {}
    for capturing in (False, True):
        sim = camera_sim("walker", seed=3)
        camera = sim.car.camera
        got: list[np.ndarray] = []

        def on_image(msg, got=got, camera=camera, sim=sim, capturing=capturing):
            got.append(pixels(msg))
            if capturing:
                camera.capture(sim.time_ns)  # drawn while the frame of this tick is in flight

        sim.subscribe(camera.spec.image_topic, on_image)
        camera.render_ahead(True)
        for _ in range(6):
            sim.run_for(1 / 30)
            if capturing:
                camera.capture(sim.time_ns)  # between ticks, with a frame drawn ahead
        camera.flush()
        runs[capturing] = got
        sim.close()
    assert len(runs[True]) == len(runs[False]) >= 6
    for plain, captured in zip(runs[False], runs[True]):
        np.testing.assert_array_equal(captured, plain)


@needs_gl
def test_a_fleets_cameras_draw_with_one_gl_context_and_the_same_frames():
    """Every camera of one model draws with the same MjrContext (meshes, textures, framebuffer made once); each
    camera's frame is the one it draws alone, and the context lives on until the last camera is closed."""
    from racecar_sim import Car
    from racecar_sim.worlds import load_world, starting_row

    world = load_world("walker", None, [], 1.0)
    cars = [Car(f"car{k + 1}", spawn=spawn, lidar=False) for k, spawn in enumerate(starting_row(world, 2))]
    sim = Simulator(world=world, cars=cars, seed=1)
    first, second = (car.camera for car in sim.cars)
    assert first is not None and second is not None
    assert first.renderer.target.context is second.renderer.target.context
    sim.run_until(0.1)
    both = [first.capture(100_000_000), second.capture(100_000_000)]
    first.close()  # the context stays for the second camera
    assert second.renderer.target.context is not None
    np.testing.assert_array_equal(second.capture(100_000_000), both[1])
    assert not np.array_equal(both[0], both[1]), "each camera shows its own view"
    sim.close()


@needs_gl
def test_a_context_begun_early_is_the_one_the_cameras_take_and_an_untaken_one_is_freed_at_exit():
    """start_shared_context (the Simulator's, as its cameras are planned): shared_context() gives the context it made
    (one only), its failure comes back as the same one line, and a process whose build stopped before any camera
    took it exits as usual (the context freed on its own thread, no hang)."""
    out = _python(
        "from racecar_sim.render import gl\n"
        "gl.start_shared_context(320, 240)\n"
        "made = gl.shared_context()\n"
        "print(made is gl.shared_context(), made.renderer != '')\n",
        {},
    )
    assert out.split() == ["True", "True"]
    assert _python("from racecar_sim.render import gl\ngl.start_shared_context()\nprint('left')\n", {}) == "left\n"
    failed = _python(
        "from racecar_sim.core.errors import RenderingError\n"
        "from racecar_sim.render import gl\n"
        "gl.start_shared_context()\n"
        "for _ in range(2):\n"
        "    try:\n        gl.shared_context()\n    except RenderingError as exc:\n        print(exc)\n",
        {"MUJOCO_GL": "off"},
    )
    first, second = failed.strip().splitlines()
    assert first == second and "MUJOCO_GL=off" in first


@needs_gl
def test_a_process_that_exits_while_its_context_is_being_made_waits_for_it():
    """A build that fails at once (a bad world) exits while start_shared_context()'s thread is still setting the
    driver up: the exit waits for the context and frees it, rather than tearing the driver down under that thread
    (glibc aborted such exits with "double free or corruption" in about a third of `racecar-sim run` calls)."""
    result = _run_python(
        "import sys, time\n"
        "from racecar_sim.render import gl\n"
        "real = gl.create_context\n"
        "def slow(width, height):\n"
        "    time.sleep(0.3)\n"
        "    made = real(width, height)\n"
        "    print('made', flush=True)\n"
        "    return made\n"
        "gl.create_context = slow\n"
        "gl.start_shared_context()\n"
        "sys.exit(0)\n",
        {},
    )
    assert result.stdout == "made\n" and result.stderr == ""
