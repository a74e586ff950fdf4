"""A message type is its .msg file: the class, its static type, the bare-name export, a test sample and the QoS
category all follow from the definition, so adding a message is one file. A service is its .srv file, the same way."""

from __future__ import annotations

import ast
import dataclasses
import pickle
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from racecar_sim import msgs
from racecar_sim.msgs import categories, generate, idl, sensor_msgs, stubs
from racecar_sim.msgs.fields import DTYPES

PROBE = "racecar_probe_msgs/msg/Sonar"
PROBE_TEXT = (
    "# A test's own sensor reading.\n"
    "std_msgs/Header header\nuint8 LOUD=3\nfloat32 range 2.5\nint16[4] echoes\nstring[] notes\n"
    "geometry_msgs/Point[] hits\nuint8[] raw\n"
)


@pytest.fixture
def probe_definition(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The shipped definitions plus one new file, as a contributor adds it, and nothing else changed."""
    root = tmp_path / "definitions"
    shutil.copytree(Path(idl.__file__).with_name("definitions"), root)
    pkg, _, name = PROBE.split("/")
    (root / pkg / "msg").mkdir(parents=True)
    (root / pkg / "msg" / f"{name}.msg").write_text(PROBE_TEXT)
    monkeypatch.setattr(idl, "_definitions_root", lambda: root)
    idl.get_spec.cache_clear()  # what a process reads once: the new file is seen as by a new process
    idl.listed_definitions.cache_clear()
    yield
    idl.get_spec.cache_clear()
    idl.listed_definitions.cache_clear()
    msgs.__dict__.pop(name, None)


def test_a_new_definition_is_a_class_an_export_and_sensor_data(probe_definition: None) -> None:
    cls = msgs.message_class(PROBE)
    assert cls is msgs.Sonar and cls.__msgtype__ == PROBE and cls.__doc__ == "A test's own sensor reading."
    default = cls()
    assert default.range == 2.5 and cls.LOUD == 3  # the definition's default and constant
    assert default.echoes.dtype == DTYPES["int16"] and default.echoes.shape == (4,)
    assert default.notes == [] and default.hits == [] and default.raw == b""
    assert categories.is_sensor_data(PROBE) is False  # not a sensor_msgs type
    msg = cls(
        msgs.Header.at(1_500_000_000, "sonar"), 0.75, np.array([1, -2, 3, -4]), ["a"], [msgs.Point(1, 2, 3)], b"xy"
    )
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(PROBE_TEXT, PROBE))
    ours = store.types[PROBE](
        store.types["std_msgs/msg/Header"](store.types["builtin_interfaces/msg/Time"](1, 500_000_000), "sonar"),
        0.75, np.array([1, -2, 3, -4], np.int16), ["a"], [store.types["geometry_msgs/msg/Point"](1.0, 2.0, 3.0)],
        np.frombuffer(b"xy", np.uint8),
    )  # fmt: skip
    assert msgs.serialize(msg) == store.serialize_cdr(ours, PROBE)
    assert msgs.deserialize(msgs.serialize(msg), PROBE) == msg


def test_classes_are_their_packages_and_pickle() -> None:
    from racecar_sim.msgs.sensor_msgs import LaserScan

    assert LaserScan is msgs.LaserScan is sensor_msgs.LaserScan is msgs.message_class("sensor_msgs/LaserScan")
    assert LaserScan.__module__ == "racecar_sim.msgs.sensor_msgs" and LaserScan.__qualname__ == "LaserScan"
    scan = LaserScan(msgs.Header.at(3, "laser"), ranges=np.arange(5, dtype=np.float32))
    assert pickle.loads(pickle.dumps(scan)) == scan
    assert not hasattr(scan, "__dict__")  # slots, as the hand-written classes had
    with pytest.raises(AttributeError, match="no sensor_msgs/msg/Lidar3D.msg"):
        sensor_msgs.Lidar3D  # noqa: B018
    with pytest.raises(KeyError, match="sensor_msgs/Lidar3D"):
        msgs.message_class("sensor_msgs/Lidar3D")


def test_a_service_is_its_srv_file() -> None:
    """Request and response are made from the two halves of the .srv file (rospy's names and rclpy's), field for field
    as gazebo_ros's and ros_control's own (noetic) .srv files, which the ROS 1 bridge ships."""
    from racecar_sim.bridges.ros1.wire import definitions_root
    from racecar_sim.msgs import controller_manager_msgs, gazebo_msgs, std_srvs

    assert gazebo_msgs.GetModelState.Request is gazebo_msgs.GetModelStateRequest
    assert std_srvs.Empty.Response is std_srvs.EmptyResponse and std_srvs.EmptyResponse() == std_srvs.EmptyResponse()
    switch = controller_manager_msgs.SwitchControllerRequest
    assert switch.__srvtype__ == "controller_manager_msgs/srv/SwitchController" and (
        switch.BEST_EFFORT,
        switch.STRICT,
    ) == (1, 2)
    assert switch.__msgtype__ == "controller_manager_msgs/srv/SwitchController_Request"
    request = gazebo_msgs.GetModelStateRequest("racecar", "world")
    assert gazebo_msgs.GetModelStateRequest.__qualname__ == "GetModelStateRequest" and not hasattr(request, "__dict__")
    assert pickle.loads(pickle.dumps(request)) == request != gazebo_msgs.GetModelStateRequest("racecar")
    assert gazebo_msgs.GetModelStateResponse().pose.orientation.w == 1.0  # nested defaults, as a message's
    with pytest.raises(AttributeError, match="no gazebo_msgs/msg/GetJointProperties.msg nor a service"):
        gazebo_msgs.GetJointProperties  # noqa: B018
    for srvtype in idl.available_srvtypes():
        pkg, _, name = srvtype.split("/")
        upstream = (definitions_root() / pkg / "srv" / f"{name}.srv").read_text().splitlines()
        cut = upstream.index("---")
        for part, lines in zip(idl.SERVICE_PARTS, (upstream[:cut], upstream[cut + 1 :])):
            theirs = idl.parse_msg("\n".join(lines), f"{pkg}/{name}{part}")
            cls = getattr(sys.modules[f"racecar_sim.msgs.{pkg}"], name + part)
            assert [f.name for f in dataclasses.fields(cls)] == [f.name for f in theirs.fields], srvtype
            assert [(f.type, f.is_array) for f in idl.get_spec(f"{srvtype}_{part}").fields] == [
                (f.type, f.is_array) for f in theirs.fields
            ], srvtype
            assert {c: v for _, c, v in idl.get_spec(cls.__msgtype__).constants} == {
                c: v for _, c, v in theirs.constants
            }


def test_the_methods_beyond_fields() -> None:
    assert msgs.Time.from_ns(-1) == msgs.Time(-1, 999_999_999)
    assert msgs.Duration.from_ns(2_000_000_001).to_ns() == 2_000_000_001
    assert msgs.Header.at(2_500_000_000, "odom") == msgs.Header(msgs.Time(2, 500_000_000), "odom")
    image = msgs.Image(height=1, width=2, encoding="rgb8", step=6, data=bytes([1, 2, 3, 4, 5, 6]))
    assert image.bgr_pixels().tolist() == [[[3, 2, 1], [6, 5, 4]]]


def _stub_type(package: str, name: str) -> str | None:
    """The type a stub's class stands for: ``pkg/msg/Name``, a service part ``pkg/srv/Name_Request``, or None for a
    service's own class (it only names its parts)."""
    services = {t.rsplit("/", 1)[1] for t in idl.available_srvtypes() if t.startswith(f"{package}/srv/")}
    for part in idl.SERVICE_PARTS:
        if name.endswith(part) and name[: -len(part)] in services:
            return f"{package}/srv/{name[: -len(part)]}_{part}"
    return None if name in services else f"{package}/msg/{name}"


def _stub_classes() -> dict[str, tuple[list[str], list[str]]]:
    """Every message class the stubs in msgs/typed declare: (its fields in order, its constants), by its type."""
    found = {}
    for path in sorted(stubs.TYPED_DIR.glob("*.pyi")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef) and (msgtype := _stub_type(path.stem, node.name)) is not None:
                declared = [s for s in node.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)]
                fields = [s.target.id for s in declared if "ClassVar" not in ast.unparse(s.annotation)]
                constants = [s.target.id for s in declared if "ClassVar" in ast.unparse(s.annotation)]
                found[msgtype] = (fields, [c for c in constants if c not in ("__msgtype__", "__srvtype__")])
    return found


def test_every_stub_is_its_definition() -> None:
    """The static types say what the classes hold: each declared class has its definition's fields and constants,
    in order. (A definition without a stub yet is typed Any; ``python -m racecar_sim.msgs.stubs`` writes it.)"""
    declared = _stub_classes()
    parts = {f"{t}_{part}" for t in idl.available_srvtypes() for part in idl.SERVICE_PARTS}
    assert declared and set(declared) <= set(idl.available_msgtypes()) | parts
    assert parts <= set(declared)  # every service's request and response is typed
    for msgtype, (fields, constants) in declared.items():
        spec = idl.get_spec(msgtype)
        assert fields == [f.name for f in spec.fields], msgtype
        assert constants == [c for _, c, _ in spec.constants], msgtype
    assert stubs.stubs()["__init__.pyi"] == (stubs.TYPED_DIR / "__init__.pyi").read_text()


def test_sensor_data_is_read_off_the_definition() -> None:
    """The stamped sensor_msgs types but a robot's joint states and a joystick: what gazebo_ros's sensor plugins
    publish (the ROS 2 bridge's sensor-data profile: keep last 5), and the ranger's Range, the GPS's NavSatFix and the
    block laser's PointCloud, each added as one file."""
    from racecar_sim.bridges.ros2 import qos

    gazebo_sensors = {
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/CameraInfo",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/Imu",
    }
    added = {"sensor_msgs/msg/Range", "sensor_msgs/msg/NavSatFix", "sensor_msgs/msg/PointCloud"}
    assert categories.sensor_data_types() == gazebo_sensors | added
    for msgtype in gazebo_sensors | added:
        assert qos.profile_name("/x", msgtype) == "sensor_data"
    assert qos.profile_name("/x", "sensor_msgs/msg/JointState") == "default"
    assert categories.is_sensor_data("sensor_msgs/Range") and not categories.is_sensor_data("sensor_msgs/JointState")
    assert not categories.is_sensor_data("nav_msgs/msg/Odometry")


def test_the_definitions_are_listed_once_a_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """A package module's lookups (about thirty as a run starts: `from racecar_sim.msgs.gazebo_msgs import ...`) read
    the list of shipped definitions made once, not the definitions' folders again each time."""
    root = Path(idl.__file__).with_name("definitions")
    for kind, listed_now in (("msg", idl.available_msgtypes()), ("srv", idl.available_srvtypes())):
        assert list(listed_now) == sorted(
            f"{p.parent.parent.name}/{kind}/{p.stem}" for p in root.glob(f"*/{kind}/*.{kind}")
        )
    listed: list[Path] = []

    def counted_root() -> Path:
        listed.append(root)
        return root

    module = sys.modules["racecar_sim.msgs.gazebo_msgs"]
    names = ("ModelStates", "LinkStates", "ModelState", "GetModelState", "SetModelStateRequest")
    made = {name: getattr(module, name) for name in names}  # made, their own files read, before the count starts
    monkeypatch.setattr(idl, "_definitions_root", counted_root)
    for name in names:
        monkeypatch.delitem(module.__dict__, name)  # so that the lookup goes through the module's __getattr__ again
        assert getattr(module, name) is made[name] and made[name].__name__ == name
    assert "gazebo_msgs/msg/ModelStates" in generate.package_types("gazebo_msgs").values()
    assert listed == []


def test_generated_modules_load_lazily() -> None:
    """A package module makes a class when it is first asked for and keeps it: later reads are plain lookups."""
    module = sys.modules["racecar_sim.msgs.geometry_msgs"]
    cls = module.Point
    assert module.__dict__["Point"] is cls is generate.message_type("geometry_msgs/Point")
