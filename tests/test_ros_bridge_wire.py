"""The ROS 1 codec (bridges/ros1/wire.py) against the real genpy classes, under the ROS interpreter.

Every type the sim publishes (one message of each topic of a short run, plus the camera's, which needs OpenGL)
and every service request and response the bridge offers: our bytes are read by genpy field for field, and what
genpy writes back is read by us into the same values.
"""

from __future__ import annotations

import dataclasses
import pickle
import subprocess
import textwrap

import numpy as np
import pytest

from racecar_sim.bridges.ros1 import (
    catalog,
    message_path,
    ros_available,
    ros_python,
    wire,
)
from racecar_sim.msgs import CameraInfo, Header, Image, RegionOfInterest, Time
from racecar_sim.msgs.controller_manager_msgs import (
    ControllerState,
    HardwareInterfaceResources,
    ListControllersResponse,
    SwitchControllerRequest,
)
from racecar_sim.msgs.gazebo_msgs import (
    GetModelStateRequest,
    GetWorldPropertiesResponse,
    SpawnModelRequest,
)
from racecar_sim.runtime import Simulator

pytestmark = pytest.mark.skipif(not ros_available(), reason="ROS 1 (rospy, genpy) is not installed")

GENPY_SIDE = textwrap.dedent("""
    import importlib, pickle, sys
    from io import BytesIO
    import genpy

    def plain(value):
        if isinstance(value, (genpy.Time, genpy.Duration)):
            return value.to_nsec()
        if isinstance(value, genpy.Message):
            return {name.lower(): plain(getattr(value, name)) for name in value.__slots__}
        if isinstance(value, (list, tuple)):
            return [plain(v) for v in value]
        return value

    out = []
    for ros_type, kind, data in pickle.load(sys.stdin.buffer):
        pkg, name = ros_type.split("/")
        if kind == "msg":
            cls = getattr(importlib.import_module(pkg + ".msg"), name)
        else:
            srv = getattr(importlib.import_module(pkg + ".srv"), name.rsplit("_", 1)[0])
            cls = srv._request_class if name.endswith("_Request") else srv._response_class
        msg = cls().deserialize(data)
        buff = BytesIO()
        msg.serialize(buff)
        out.append((plain(msg), buff.getvalue()))
    pickle.dump(out, sys.stdout.buffer, protocol=4)
""")


def plain(value: object) -> object:
    """The sim's message as nested dicts with ROS 1's lower-cased names; times as integer nanoseconds."""
    if isinstance(value, Time) or type(value).__name__ == "Duration":
        return value.to_ns()
    if dataclasses.is_dataclass(value):
        return {f.name.lower(): plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, np.ndarray):
        return value.tolist() if value.dtype != np.uint8 else value.tobytes()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def assert_same(ours: object, theirs: object, path: str = "") -> None:
    if isinstance(ours, dict):
        assert isinstance(theirs, dict), path
        theirs = dict(theirs)
        if "stamp" in ours and "seq" in theirs:  # a std_msgs/Header: ROS 1's seq is not in the sim's class
            theirs.pop("seq")
        assert set(ours) == set(theirs), f"{path}: {sorted(ours)} != {sorted(theirs)}"
        for key in ours:
            assert_same(ours[key], theirs[key], f"{path}.{key}")
    elif isinstance(ours, list):
        assert len(ours) == len(theirs), path
        for i, (a, b) in enumerate(zip(ours, theirs)):
            assert_same(a, b, f"{path}[{i}]")
    elif isinstance(ours, float):
        assert theirs == pytest.approx(ours, rel=1e-6, abs=1e-30), path  # float32 fields round
    else:
        assert ours == theirs, path


def sim_messages() -> dict[str, object]:
    """One message of every type on the bus of a 1 s run, plus the camera's (rendered only with OpenGL)."""
    found: dict[str, object] = {}
    sim = Simulator(world="empty", camera=False)
    sim.bus.tap(lambda topic, msg: found.setdefault(wire.type_of(type(msg)), msg))
    sim.run_for(1.0)
    sim.close()
    header = Header.at(1_234_567_890, "camera")
    found["sensor_msgs/msg/Image"] = Image(header, 2, 3, "bgr8", 0, 9, bytes(range(18)))
    found["sensor_msgs/msg/CameraInfo"] = CameraInfo(
        header,
        480,
        640,
        "plumb_bob",
        np.arange(5.0),
        np.arange(9.0),
        np.eye(3).ravel(),
        np.arange(12.0),
        1,
        2,
        RegionOfInterest(1, 2, 3, 4, True),
    )
    return found


def service_parts() -> list[object]:
    resources = [HardwareInterfaceResources("hardware_interface::EffortJointInterface", ["a_joint", "b_joint"])]
    return [
        GetModelStateRequest("racecar", "world"),
        SpawnModelRequest("car2", "<robot name='x'/>", "/car2", reference_frame="map"),
        GetWorldPropertiesResponse(12.5, ["ground_plane", "racecar"], False, True, "ok"),
        SwitchControllerRequest(["left"], ["right"], 2, True, 0.5),
        ListControllersResponse([ControllerState("c", "running", "effort_controllers/X", resources)]),
    ] + [cls() for srv in sorted(set(catalog.SERVICE_TYPES.values())) for cls in wire.service_classes(srv)]


def test_codec_matches_genpy_both_ways() -> None:
    messages = list(sim_messages().values()) + service_parts()
    assert len(messages) >= 25
    batch = []
    for msg in messages:
        msgtype = wire.type_of(type(msg))
        batch.append((wire.ros1_name(msgtype), "srv" if "/srv/" in msgtype else "msg", wire.serialize(msg, 42)))
    env = {"PYTHONPATH": str(message_path()), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [ros_python(), "-c", GENPY_SIDE],
        input=pickle.dumps(batch, protocol=4),
        env=env,
        capture_output=True,
        check=True,
    )
    for msg, (ros_type, _, ours), (theirs, written) in zip(messages, batch, pickle.loads(done.stdout)):
        assert_same(plain(msg), theirs, ros_type)  # genpy reads our bytes as the same values
        if isinstance(theirs, dict) and isinstance(theirs.get("header"), dict):
            assert theirs["header"]["seq"] == 42
        assert written == ours, ros_type  # and writes the very same bytes
        assert_same(plain(msg), plain(wire.deserialize(written, type(msg))), ros_type)  # which we read back
