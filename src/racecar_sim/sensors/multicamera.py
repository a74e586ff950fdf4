"""gazebo_ros_multicamera: a `<sensor type="multicamera">` (the ZED as the stereo pair it is) publishing each of its
cameras as gazebo_ros_camera would, the right one with the pair's baseline in its projection.

As gazebo_plugins/src/gazebo_ros_multicamera.cpp (ROS 1) sets its cameras up: a camera whose name holds "left" is
published under <cameraName>/left, one whose name holds "right" under <cameraName>/right (any other is refused: the
plugin drives those two), each with <imageTopicName> (default image_raw) and <cameraInfoTopicName> (default
camera_info) under <robotNamespace>, both stamped in <frameName> (default world); the right camera's CameraInfo P has
Tx = -fx * <hackBaseline> (the left's 0). <cameraName> defaults to the sensor's name here. Each camera is the sensor's
own `<camera>` block at the sensor's pose composed with the camera's <pose>, rendered as the camera node renders one
(sensors/camera.py), at the sensor's rate.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.names import CarNames
from racecar_sim.core.transforms import compose, quat_from_rpy, quat_to_matrix
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.nodes import Node, NodeBase, NodeContext, Parts
from racecar_sim.sensors.camera_spec import CameraSpec
from racecar_sim.sensors.sensor_xml import join_topic

PLUGIN = "libgazebo_ros_multicamera.so"
SIDES = ("left", "right")


def _rpy(q: np.ndarray) -> tuple[float, float, float]:
    """Fixed-axis roll, pitch, yaw (URDF's) of a unit quaternion (w, x, y, z)."""
    r = quat_to_matrix(q)
    return (
        math.atan2(r[2, 1], r[2, 2]),
        math.asin(max(-1.0, min(1.0, -r[2, 0]))),
        math.atan2(r[1, 0], r[0, 0]),
    )


def _pose(text: str | None, where: str) -> tuple[np.ndarray, np.ndarray]:
    values = [float(v) for v in (text or "0 0 0 0 0 0").split()]
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{where}: <pose> '{text}' is not 6 numbers")
    return np.array(values[:3]), quat_from_rpy(values[3:])


def stereo_specs(sensor: Sensor) -> tuple[CameraSpec, ...]:
    """One camera spec per camera of a multicamera block, left then right (DescriptionError naming what is wrong)."""
    where = f"<sensor type='multicamera' name='{sensor.name}'> on link {sensor.link}"
    plugin = next((p for p in sensor.plugins if p.filename == PLUGIN), None)
    if plugin is None:
        raise DescriptionError(f"{where}: no <plugin filename='{PLUGIN}'> inside")
    params = plugin.params
    namespace, name = params.get("robotNamespace", ""), params.get("cameraName") or sensor.name
    frame = (params.get("frameName") or "/world").lstrip("/")
    cameras = sensor.element.findall("camera")
    specs = {}
    for camera in cameras:
        own = camera.get("name", "")
        side = next((s for s in SIDES if s in own), None)
        if side is None or side in specs:
            raise DescriptionError(f"{where}: <camera name='{own}'>: {PLUGIN} drives one 'left' and one 'right' camera")
        position, quat = compose(
            np.array(sensor.pose.xyz), quat_from_rpy(sensor.pose.rpy), *_pose(camera.findtext("pose"), where)
        )
        element = copy.copy(sensor.element)
        for other in element.findall("camera"):
            element.remove(other)
        element.append(camera)
        single = dataclasses.replace(sensor, element=element)
        spec = CameraSpec.from_sensor(single)
        topic = f"{name}/{side}"
        baseline = float(params.get("hackBaseline", "0") or 0) if side == "right" else 0.0
        specs[side] = dataclasses.replace(
            spec,
            name=f"{sensor.name}_{own}",
            pose=Origin((float(position[0]), float(position[1]), float(position[2])), _rpy(quat)),
            image_topic=join_topic(namespace, f"{topic}/{params.get('imageTopicName') or 'image_raw'}"),
            info_topic=join_topic(namespace, f"{topic}/{params.get('cameraInfoTopicName') or 'camera_info'}"),
            frame_id=frame,
            baseline=baseline,
        )
    if set(specs) != set(SIDES):
        raise DescriptionError(f"{where}: {PLUGIN} needs a 'left' and a 'right' <camera>, found {sorted(specs)}")
    return specs["left"], specs["right"]


class StereoPair(NodeBase):
    """The multicamera's node: one camera node per camera of the pair, their hooks run together."""

    def __init__(self, cameras: list[Node]) -> None:
        self.cameras = cameras

    def reset(self, seed: int) -> None:
        """Each camera's noise from `seed`."""
        for camera in self.cameras:
            camera.reset(seed)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Each camera renders the recompiled model."""
        for camera in self.cameras:
            camera.rebind(model, data)

    def close(self) -> None:
        """Each camera frees its GL objects."""
        for camera in self.cameras:
            camera.close()


def stereo_parts(specs: tuple[CameraSpec, ...], names: CarNames = CarNames()) -> Parts:
    """A multicamera's parts: the MuJoCo camera of each spec, as camera0, camera1, ..."""
    owner = f"multicamera '{specs[0].name}'" if specs else "multicamera"
    return Parts.cameras(owner, **{f"camera{i}": names.mj(spec.name) for i, spec in enumerate(specs)})


def stereo_pair(ctx: NodeContext, specs: tuple[CameraSpec, ...]) -> StereoPair:
    """The node of a multicamera block: a camera node per spec (sensors/camera.py), each rendering its part."""
    from racecar_sim.sensors.camera import CameraPublisher

    return StereoPair([CameraPublisher(ctx, spec, f"camera{i}") for i, spec in enumerate(specs)])
