"""Message classes, .msg parsing and CDR bytes, checked against rosbags as the reference."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from racecar_sim import msgs
from racecar_sim.msgs import cdr, idl
from racecar_sim.msgs._base import Message
from racecar_sim.msgs.fields import DTYPES, SCALARS


def _stamped(ns: int, frame: str) -> msgs.Header:
    return msgs.Header.at(ns, frame)


def _transform(child: str, x: float) -> msgs.TransformStamped:
    return msgs.TransformStamped(
        header=_stamped(5_000_000_123, "base_link"),
        child_frame_id=child,
        transform=msgs.Transform(
            translation=msgs.Vector3(x, -0.5, 0.125),
            rotation=msgs.Quaternion(0.0, 0.0, math.sin(0.3), math.cos(0.3)),
        ),
    )


def _odometry() -> msgs.Odometry:
    odom = msgs.Odometry(header=_stamped(12_345_678_901, "odom"), child_frame_id="base_link")
    odom.pose.pose.position = msgs.Point(1.5, -2.25, 0.05)
    odom.pose.pose.orientation = msgs.Quaternion(0.0, 0.0, 0.2, 0.98)
    odom.pose.covariance = np.arange(36, dtype=np.float64) * 0.01
    odom.twist.twist.linear = msgs.Vector3(2.0, 0.1, 0.0)
    odom.twist.twist.angular = msgs.Vector3(0.0, 0.0, -0.7)
    odom.twist.covariance = np.linspace(0.0, 1.0, 36)
    return odom


def _image(rng: np.random.Generator) -> msgs.Image:
    return msgs.Image(
        header=_stamped(3_000_000_000, "camera_link"),
        height=48,
        width=64,
        encoding="bgr8",
        step=64 * 3,
        data=rng.integers(0, 256, 48 * 64 * 3, dtype=np.uint8).tobytes(),
    )


def _camera_info() -> msgs.CameraInfo:
    return msgs.CameraInfo(
        header=_stamped(3_000_000_000, "camera_link"),
        height=480,
        width=640,
        distortion_model="plumb_bob",
        d=np.array([0.1, -0.05, 0.001, 0.0, 0.002]),
        k=np.array([525.0, 0, 320.5, 0, 525.0, 240.5, 0, 0, 1]),
        r=np.eye(3).ravel(),
        p=np.array([525.0, 0, 320.5, -37.5, 0, 525.0, 240.5, 0, 0, 0, 1, 0]),
        binning_x=1,
        binning_y=2,
        roi=msgs.RegionOfInterest(10, 20, 100, 200, True),
    )


def _laser_scan(rng: np.random.Generator) -> msgs.LaserScan:
    return msgs.LaserScan(
        header=_stamped(1_025_000_000, "laser"),
        angle_min=-2.25,
        angle_max=2.25,
        angle_increment=0.0043,
        time_increment=1.5e-5,
        scan_time=0.025,
        range_min=0.1,
        range_max=10.0,
        ranges=rng.uniform(0.1, 10.0, 1081).astype(np.float32),
        intensities=np.array([1.0, np.nan, np.inf], dtype=np.float32),
    )


SAMPLES: dict[str, Callable[[np.random.Generator], Message]] = {
    "builtin_interfaces/msg/Time": lambda _: msgs.Time(1_700_000_000, 999_999_999),
    "builtin_interfaces/msg/Duration": lambda _: msgs.Duration(-3, 250),
    "std_msgs/msg/Header": lambda _: _stamped(42_000_000_007, "map"),
    "std_msgs/msg/Float64": lambda _: msgs.Float64(-0.1),
    "std_msgs/msg/String": lambda _: msgs.String("héllo wörld"),
    "std_msgs/msg/Int8": lambda _: msgs.Int8(-128),
    "geometry_msgs/msg/Point": lambda _: msgs.Point(1.0, 2.0, 3.5),
    "geometry_msgs/msg/Vector3": lambda _: msgs.Vector3(-1.0, 0.25, 1e-9),
    "geometry_msgs/msg/Quaternion": lambda _: msgs.Quaternion(0.1, 0.2, 0.3, 0.9),
    "geometry_msgs/msg/Pose": lambda _: msgs.Pose(msgs.Point(1, 2, 3), msgs.Quaternion(w=0.5)),
    "geometry_msgs/msg/PoseWithCovariance": lambda rng: msgs.PoseWithCovariance(
        msgs.Pose(msgs.Point(4, 5, 6)), rng.normal(size=36)
    ),
    "geometry_msgs/msg/PoseStamped": lambda _: msgs.PoseStamped(_stamped(7, "map"), msgs.Pose(msgs.Point(-1, -2, -3))),
    "geometry_msgs/msg/Twist": lambda _: msgs.Twist(msgs.Vector3(1, 0, 0), msgs.Vector3(0, 0, 2)),
    "geometry_msgs/msg/TwistWithCovariance": lambda rng: msgs.TwistWithCovariance(
        msgs.Twist(msgs.Vector3(0.5, 0, 0)), rng.normal(size=36)
    ),
    "geometry_msgs/msg/Transform": lambda _: _transform("x", 1.0).transform,
    "geometry_msgs/msg/TransformStamped": lambda _: _transform("laser", 0.265),
    "nav_msgs/msg/Odometry": lambda _: _odometry(),
    "geometry_msgs/msg/PoseWithCovarianceStamped": lambda rng: msgs.PoseWithCovarianceStamped(
        _stamped(2_500_000_000, "map"),
        msgs.PoseWithCovariance(
            msgs.Pose(msgs.Point(1.5, -2.0, 0.0), msgs.Quaternion(0, 0, 0.6, 0.8)), rng.normal(size=36)
        ),
    ),
    "nav_msgs/msg/MapMetaData": lambda _: msgs.MapMetaData(
        msgs.Time(3, 4), 0.0625, 7, 5, msgs.Pose(msgs.Point(-10.025, -3.5, 0.0))
    ),
    "nav_msgs/msg/OccupancyGrid": lambda rng: msgs.OccupancyGrid(
        _stamped(0, "map"),
        msgs.MapMetaData(msgs.Time(0, 0), 0.0625, 7, 5, msgs.Pose(msgs.Point(-1.0, 2.0, 0.0))),
        rng.choice(np.array([-1, 0, 100], np.int8), 35),
    ),
    "sensor_msgs/msg/JointState": lambda _: msgs.JointState(
        header=_stamped(99, ""),
        name=["left_rear_wheel_joint", "right_steering_hinge_joint", ""],
        position=np.array([0.1, -0.2, 0.3]),
        velocity=np.array([10.0, 0.0, -1.0]),
        effort=np.zeros(0),
    ),
    "sensor_msgs/msg/LaserScan": _laser_scan,
    "sensor_msgs/msg/Joy": lambda _: msgs.Joy(
        _stamped(2_050_000_000, ""),
        np.array([0.0, 1.0, -0.25, 1e-3, -1.0000305], dtype=np.float32),
        np.array([0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0], dtype=np.int32),
    ),
    "sensor_msgs/msg/Image": _image,
    "sensor_msgs/msg/CompressedImage": lambda rng: msgs.sensor_msgs.CompressedImage(
        _stamped(33_000_000, "camera_link"), "bgr8; jpeg compressed bgr8", rng.bytes(1001)
    ),
    "sensor_msgs/msg/RegionOfInterest": lambda _: msgs.RegionOfInterest(1, 2, 3, 4, True),
    "sensor_msgs/msg/CameraInfo": lambda _: _camera_info(),
    "sensor_msgs/msg/Imu": lambda rng: msgs.Imu(
        _stamped(10_000_000, "imu_link"),
        msgs.Quaternion(0.0, 0.1, 0.2, 0.97),
        rng.normal(size=9),
        msgs.Vector3(0.01, -0.02, 0.5),
        rng.normal(size=9),
        msgs.Vector3(0.1, 0.2, 9.81),
        rng.normal(size=9),
    ),
    "sensor_msgs/msg/PointField": lambda _: msgs.PointField("z", 8, msgs.PointField.FLOAT32, 1),
    "sensor_msgs/msg/PointCloud2": lambda rng: msgs.PointCloud2(
        _stamped(100_000_000, "depth_link"),
        1,
        3,
        [msgs.PointField("x", 0, 7, 1), msgs.PointField("y", 4, 7, 1), msgs.PointField("z", 8, 7, 1)],
        False,
        12,
        36,
        rng.normal(size=9).astype("<f4").tobytes(),
        True,
    ),
    "tf2_msgs/msg/TFMessage": lambda _: msgs.TFMessage([_transform("base_link", 0.0), _transform("laser", 0.265)]),
    "rosgraph_msgs/msg/Clock": lambda _: msgs.Clock(msgs.Time(12, 500_000_000)),
    "ackermann_msgs/msg/AckermannDrive": lambda _: msgs.AckermannDrive(0.375, 1.5, 2.0, 0.5, 0.25),
    "ackermann_msgs/msg/AckermannDriveStamped": lambda _: msgs.AckermannDriveStamped(
        _stamped(1_000_000_000, "base_link"), msgs.AckermannDrive(-0.25, speed=1.75)
    ),
    "control_msgs/msg/JointControllerState": lambda _: msgs.JointControllerState(
        _stamped(1_230_000_000, ""), 20.0, 19.5, 0.25, 0.5, 0.0025, 0.5, 1.0, 0.1, 0.5, 2.0, True
    ),
    "controller_manager_msgs/msg/HardwareInterfaceResources": lambda _: msgs.HardwareInterfaceResources(
        "hardware_interface::EffortJointInterface", ["left_rear_wheel_joint", "right_rear_wheel_joint"]
    ),
    "controller_manager_msgs/msg/ControllerState": lambda _: msgs.ControllerState(
        "left_rear_wheel_velocity_controller",
        "running",
        "effort_controllers/JointVelocityController",
        [msgs.HardwareInterfaceResources("hardware_interface::EffortJointInterface", ["left_rear_wheel_joint"])],
    ),
    "gazebo_msgs/msg/ModelState": lambda _: msgs.ModelState(
        "car2", msgs.Pose(msgs.Point(1, 2, 0.05), msgs.Quaternion(w=1.0)), msgs.Twist(msgs.Vector3(0.5, 0, 0)), "world"
    ),
    "gazebo_msgs/msg/ModelStates": lambda _: msgs.ModelStates(
        ["ground_plane", "racecar"],
        [msgs.Pose(), msgs.Pose(msgs.Point(1, 0, 0))],
        [msgs.Twist(), msgs.Twist(msgs.Vector3(1, 0, 0))],
    ),
    "gazebo_msgs/msg/LinkStates": lambda _: msgs.LinkStates(
        ["racecar::base_link"], [msgs.Pose(msgs.Point(0, 1, 0))], [msgs.Twist(angular=msgs.Vector3(0, 0, 0.5))]
    ),
}


@pytest.fixture(scope="module")
def typestore() -> Any:
    """Rosbags' ROS 2 Jazzy types (the wheels' distro) plus every type it lacks, registered from our .msg files."""
    store = get_typestore(Stores.ROS2_JAZZY)
    missing: dict[str, Any] = {}
    for msgtype in idl.available_msgtypes():
        if msgtype not in store.types:
            missing.update(get_types_from_msg(idl.get_spec(msgtype).text, msgtype))
    store.register(missing)
    return store


def to_rosbags(msg: Any, store: Any) -> Any:
    """The rosbags equivalent of one of our messages (uint8[] bytes become a uint8 array)."""
    if not isinstance(msg, Message):
        if isinstance(msg, list):
            return [to_rosbags(item, store) for item in msg]
        if isinstance(msg, (bytes, bytearray)):
            return np.frombuffer(msg, dtype=np.uint8)
        return msg
    values = {f.name: to_rosbags(getattr(msg, f.name), store) for f in dataclasses.fields(msg)}
    return store.types[msg.__msgtype__](**values)


def _random_value(spec: idl.FieldSpec, rng: np.random.Generator) -> Any:
    """A random value of one field, of the type the definition gives (float32 values exactly representable)."""
    count = spec.size if spec.size is not None else int(rng.integers(0, 4))
    if spec.is_array and spec.type in ("uint8", "byte", "char"):
        return rng.bytes(count)
    if spec.is_array and spec.is_primitive and spec.type != "string":
        return np.array([_random_value(dataclasses.replace(spec, is_array=False), rng) for _ in range(count)],
                        dtype=DTYPES[spec.type])  # fmt: skip
    if spec.is_array:
        return [_random_value(dataclasses.replace(spec, is_array=False, size=None), rng) for _ in range(count)]
    if spec.type == "string":
        return "".join(rng.choice(list("abcdé_/ "), int(rng.integers(0, 9))))
    if spec.type == "bool":
        return bool(rng.integers(0, 2))
    if spec.type in ("float32", "float64"):
        return float(np.float32(rng.normal(scale=100.0)))
    if spec.type in SCALARS:  # an integer type: any value of its width
        return int.from_bytes(
            rng.bytes(SCALARS[spec.type][1]), "little", signed=not spec.type.startswith(("u", "b", "c"))
        )
    return _generated_sample(spec.type, rng)


def _generated_sample(msgtype: str, rng: np.random.Generator) -> Message:
    """A random instance of any defined type, every field set from its definition."""
    values = {f.name: _random_value(f, rng) for f in idl.get_spec(msgtype).fields}
    return msgs.message_class(msgtype)(**values)  # type: ignore[no-any-return]


def sample(msgtype: str, rng: np.random.Generator) -> Message:
    """The hand-made sample of a type, or one made from its definition: every definition has one."""
    return SAMPLES[msgtype](rng) if msgtype in SAMPLES else _generated_sample(msgtype, rng)


def _cases() -> list[Any]:
    return [pytest.param(t, id=t.split("/")[-1]) for t in idl.available_msgtypes()]


def test_samples_cover_every_definition(typestore: Any) -> None:
    """The hand-made samples are of defined types; a definition without one gets a sample from its fields, and every
    type's sample made so goes out as rosbags writes it."""
    assert set(SAMPLES) <= set(idl.available_msgtypes())
    rng = np.random.default_rng(5)
    for msgtype in idl.available_msgtypes():
        generated = _generated_sample(msgtype, rng)
        data = msgs.serialize(generated)
        assert data == typestore.serialize_cdr(to_rosbags(generated, typestore), msgtype), msgtype
        assert msgs.deserialize(data, msgtype) == generated


@pytest.mark.parametrize("msgtype", _cases())
def test_serialize_matches_rosbags(msgtype: str, typestore: Any) -> None:
    msg = sample(msgtype, np.random.default_rng(7))
    assert msgs.msgtype_of(msg) == msgtype
    assert msgs.serialize(msg) == typestore.serialize_cdr(to_rosbags(msg, typestore), msgtype)


@pytest.mark.parametrize("msgtype", _cases())
def test_default_instance_matches_rosbags(msgtype: str, typestore: Any) -> None:
    msg = msgs.message_class(msgtype)()
    assert msgs.serialize(msg) == typestore.serialize_cdr(to_rosbags(msg, typestore), msgtype)


@pytest.mark.parametrize("msgtype", _cases())
def test_deserialize_round_trip(msgtype: str) -> None:
    msg = sample(msgtype, np.random.default_rng(7))
    data = msgs.serialize(msg)
    back = msgs.deserialize(data, msgtype)
    assert msgs.serialize(back) == data
    if msgtype != "sensor_msgs/msg/LaserScan":  # its float32 scalars round, and NaN != NaN
        assert back == msg


def test_laser_scan_round_trip_values() -> None:
    scan = SAMPLES["sensor_msgs/msg/LaserScan"](np.random.default_rng(1))
    assert isinstance(scan, msgs.LaserScan)
    back = msgs.deserialize(msgs.serialize(scan), "sensor_msgs/LaserScan")
    assert back.header == scan.header
    assert back.angle_min == pytest.approx(scan.angle_min, rel=1e-7)
    assert back.ranges.dtype == np.float32
    np.testing.assert_array_equal(back.ranges, scan.ranges)
    np.testing.assert_array_equal(back.intensities, scan.intensities)  # NaN and inf survive


@pytest.mark.parametrize("msgtype", _cases())
def test_dataclass_fields_match_msg_definition(msgtype: str) -> None:
    cls = msgs.message_class(msgtype)
    spec = idl.get_spec(msgtype)
    assert [f.name for f in dataclasses.fields(cls)] == [f.name for f in spec.fields]
    assert cls.__doc__
    assert cls.__msgtype__ == msgtype
    default = cls()
    for field_spec in spec.fields:
        value = getattr(default, field_spec.name)
        if field_spec.is_array and field_spec.type in ("uint8", "byte", "char"):
            assert value == b""
        elif field_spec.is_array and field_spec.is_primitive and field_spec.type != "string":
            assert isinstance(value, np.ndarray)
            assert value.shape == (field_spec.size or 0,)
        elif field_spec.is_array:
            assert value == []


@pytest.mark.parametrize("msgtype", ["sensor_msgs/msg/LaserScan", "nav_msgs/msg/Odometry",
                                     "ackermann_msgs/msg/AckermannDriveStamped"])  # fmt: skip
def test_schema_text_parses_in_rosbags(msgtype: str, typestore: Any) -> None:
    text = msgs.schema_text(msgtype)
    assert text.count("=" * 80 + "\nMSG: ") == len(idl.dependencies(msgtype))
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(text, msgtype))
    msg = SAMPLES[msgtype](np.random.default_rng(3))
    decoded = store.deserialize_cdr(msgs.serialize(msg), msgtype)
    reference = typestore.fielddefs[msgtype]
    assert [f[0] for f in store.fielddefs[msgtype][1]] == [f[0] for f in reference[1]]
    assert decoded.header.frame_id == msg.header.frame_id  # type: ignore[attr-defined]


def test_schema_lists_each_dependency_once_depth_first() -> None:
    assert idl.dependencies("tf2_msgs/TFMessage") == (
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Transform",
        "geometry_msgs/msg/Vector3",
        "geometry_msgs/msg/Quaternion",
    )


def test_parse_msg_features() -> None:
    text = (
        "# comment line\n"
        "int32 LIMIT=5  # a constant\n"
        'string GREETING="a # b"\n'
        "Header header\n"
        "Point p\n"
        "geometry_msgs/msg/Vector3 v\n"
        "float64[<=3] bounded\n"
        "string<=8[2] names\n"
        "uint8 flag 1\n"
        "bool[] bits\n"
    )
    spec = idl.parse_msg(text, "my_pkg/Thing")
    assert spec.msgtype == "my_pkg/msg/Thing"
    assert [(c[1], c[2]) for c in spec.constants] == [("LIMIT", "5"), ("GREETING", '"a # b"')]
    assert [(f.name, f.type, f.is_array, f.size) for f in spec.fields] == [
        ("header", "std_msgs/msg/Header", False, None),
        ("p", "my_pkg/msg/Point", False, None),
        ("v", "geometry_msgs/msg/Vector3", False, None),
        ("bounded", "float64", True, None),
        ("names", "string", True, 2),
        ("flag", "uint8", False, None),
        ("bits", "bool", True, None),
    ]


def test_parse_msg_rejects_garbage() -> None:
    with pytest.raises(ValueError, match="my_pkg/msg/Bad line 2"):
        idl.parse_msg("int32 a\nfloat64[x y\n", "my_pkg/Bad")


def test_image_data_accepts_buffers(typestore: Any) -> None:
    raw = np.random.default_rng(0).integers(0, 256, (4, 5, 3), dtype=np.uint8)
    reference = msgs.serialize(msgs.Image(height=4, width=5, step=15, data=raw.tobytes()))
    for data in (bytearray(raw.tobytes()), memoryview(raw.tobytes()), raw, np.asfortranarray(raw)):
        assert msgs.serialize(msgs.Image(height=4, width=5, step=15, data=data)) == reference


def test_arrays_accept_lists_and_other_dtypes() -> None:
    a = msgs.LaserScan(ranges=[1.0, 2.0, 3.0])  # type: ignore[arg-type]
    b = msgs.LaserScan(ranges=np.array([1.0, 2.0, 3.0], dtype=np.float64))
    assert msgs.serialize(a) == msgs.serialize(b)


def test_bad_field_type_names_type_and_field() -> None:
    with pytest.raises(TypeError, match=r"sensor_msgs/msg/LaserScan: field 'angle_min'"):
        msgs.serialize(msgs.LaserScan(angle_min="wide"))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"Image: field 'height'"):
        msgs.serialize(msgs.Image(height=1.5))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"std_msgs/msg/Header: field 'frame_id'"):
        msgs.serialize(msgs.Header(frame_id=7))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"LaserScan: field 'ranges'"):
        msgs.serialize(msgs.LaserScan(ranges=None))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"Image: field 'data'"):
        msgs.serialize(msgs.Image(data="pixels"))  # type: ignore[arg-type]


def test_bad_values_raise_value_error() -> None:
    with pytest.raises(ValueError, match=r"std_msgs/msg/Int8: field 'data'"):
        msgs.serialize(msgs.Int8(300))
    with pytest.raises(ValueError, match=r"AckermannDrive: field 'speed'"):
        msgs.serialize(msgs.AckermannDrive(speed=1e39))
    with pytest.raises(ValueError, match=r"PoseWithCovariance: field 'covariance'.*36"):
        msgs.serialize(msgs.PoseWithCovariance(covariance=np.zeros(35)))


def test_nested_list_errors_name_the_element() -> None:
    tf = msgs.TFMessage([_transform("a", 0.0), msgs.Transform()])  # type: ignore[list-item]
    with pytest.raises(TypeError, match=r"tf2_msgs/msg/TFMessage: field 'transforms\[1\]'"):
        msgs.serialize(tf)


def test_repeated_name_lists_and_pose_arrays_match_rosbags(typestore: Any) -> None:
    """Name lists are reused while they repeat at the same alignment, and Pose / Twist arrays are packed in one go:
    each message, repeated or changed, is still the bytes rosbags writes."""
    rng = np.random.default_rng(3)
    names = [f"racecar::{'x' * k}_link" for k in range(9)]  # every length modulo 4
    sequence = []
    for links in (names, names, names[:5], names[:5] + ["z"], names):
        sequence.append(
            msgs.LinkStates(
                list(links),
                [msgs.Pose(msgs.Point(*rng.normal(size=3)), msgs.Quaternion(*rng.normal(size=4))) for _ in links],
                [msgs.Twist(msgs.Vector3(*rng.normal(size=3)), msgs.Vector3(*rng.normal(size=3))) for _ in links],
            )
        )
    for frame in ("", "a", "ab", "abc", "", "abcd"):  # the same joint names after headers of every alignment
        sequence.append(
            msgs.JointState(
                _stamped(5, frame), ["left_rear_wheel_joint", "hinge"], np.array([0.5, 1.0]), np.zeros(2), np.zeros(0)
            )
        )
    for msg in sequence:
        assert msgs.serialize(msg) == typestore.serialize_cdr(to_rosbags(msg, typestore), msgs.msgtype_of(msg))
    empty = msgs.LinkStates(["a"], [], [])
    assert msgs.serialize(empty) == typestore.serialize_cdr(to_rosbags(empty, typestore), "gazebo_msgs/msg/LinkStates")


def test_a_bad_element_of_a_packed_array_is_named() -> None:
    poses = [msgs.Pose(), msgs.Pose(msgs.Point(1.0, "north", 0.0))]  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"gazebo_msgs/msg/ModelStates: field 'pose\[1\]'.*position.y"):
        msgs.serialize(msgs.ModelStates(["a", "b"], poses, [msgs.Twist(), msgs.Twist()]))
    with pytest.raises(TypeError, match=r"field 'name\[1\]'"):
        msgs.serialize(msgs.ModelStates(["a", np.array([1, 2])], [], []))  # type: ignore[list-item]


def test_nan_is_carried() -> None:
    data = msgs.serialize(msgs.Float64(math.nan))
    assert math.isnan(msgs.deserialize(data, "std_msgs/msg/Float64").data)


def test_deserialize_rejects_bad_data() -> None:
    with pytest.raises(ValueError, match="not little-endian CDR"):
        msgs.deserialize(b"\x00\x00\x00\x00abcd", "std_msgs/String")
    with pytest.raises(ValueError, match="std_msgs/msg/String: field 'data'"):
        msgs.deserialize(msgs.serialize(msgs.String("hello"))[:-3], "std_msgs/String")


def test_registry_and_helpers() -> None:
    assert msgs.message_class("sensor_msgs/LaserScan") is msgs.LaserScan
    assert msgs.msgtype_of(msgs.Odometry) == "nav_msgs/msg/Odometry"
    with pytest.raises(KeyError):
        msgs.message_class("sensor_msgs/msg/NoSuchType")
    with pytest.raises(TypeError):
        msgs.msgtype_of(3.0)
    with pytest.raises(TypeError, match="instance"):
        msgs.serialize(msgs.LaserScan)
    assert msgs.Time.from_ns(-1) == msgs.Time(-1, 999_999_999)
    assert msgs.Time.from_ns(12_000_000_345).to_ns() == 12_000_000_345
    assert msgs.Header.at(2_500_000_000, "odom") == msgs.Header(msgs.Time(2, 500_000_000), "odom")
    assert "<921600 bytes>" in repr(msgs.Image(data=bytes(921600)))


# --- one field model under both encoders ------------------------------------------------------------------------
PROBE_MSG = "std_msgs/Header header\nfloat64 x\nstring[] names\nint16[2] pair\n"


@dataclasses.dataclass(eq=False, repr=False, slots=True)
class Probe(Message):
    """A type that only the test's field model defines."""

    __msgtype__ = "racecar_test_msgs/msg/Probe"

    header: msgs.Header = dataclasses.field(default_factory=msgs.Header)
    x: float = 0.0
    names: list[str] = dataclasses.field(default_factory=list)
    pair: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2, np.int16))


def test_both_encoders_compile_from_the_one_field_model(monkeypatch: pytest.MonkeyPatch, typestore: Any) -> None:
    """A type defined in the field model and nowhere else goes out through the CDR encoder as rosbags writes it and
    through the ROS 1 encoder with ROS 1's differences (Header.seq, time as two uint32, no alignment, no NUL)."""
    from racecar_sim.bridges.ros1 import wire
    from racecar_sim.msgs import fields

    real, probe = fields.get_spec, idl.parse_msg(PROBE_MSG, Probe.__msgtype__)
    monkeypatch.setattr(fields, "get_spec", lambda t: probe if t == Probe.__msgtype__ else real(t))
    msg = Probe(_stamped(7_000_000_005, "map"), 1.5, ["a", "bcd"], np.array([-2, 3], np.int16))
    typestore.register(get_types_from_msg(PROBE_MSG, Probe.__msgtype__))
    assert msgs.serialize(msg) == typestore.serialize_cdr(to_rosbags(msg, typestore), Probe.__msgtype__)
    ros1 = (
        b"\x2a\0\0\0"
        + b"\x07\0\0\0\x05\0\0\0"
        + b"\x03\0\0\0map"
        + np.float64(1.5).tobytes()
        + b"\x02\0\0\0"
        + b"\x01\0\0\0a"
        + b"\x03\0\0\0bcd"
        + np.array([-2, 3], "<i2").tobytes()
    )
    assert wire.serialize(msg, 42) == ros1
    model = fields.message_fields(Probe.__msgtype__)
    assert [f.name for f in model] == ["header", "x", "names", "pair"]
    assert wire.fields(Probe.__msgtype__) is model  # the ROS 1 layout is the model's very fields


@pytest.mark.parametrize("msgtype", _cases())
def test_ros1_layout_is_the_field_model(msgtype: str) -> None:
    """Every message type's ROS 1 layout is the model's FieldSpec objects, ROS 1's differences aside, and the ROS 1
    .msg shipped for genpy (bridges/ros1/definitions) holds the same fields."""
    from racecar_sim.bridges.ros1 import wire
    from racecar_sim.msgs.fields import message_fields

    model, ros1 = message_fields(msgtype), wire.fields(msgtype)
    assert all(f.attr == f.name for f in model)
    if msgtype == "std_msgs/msg/Header":
        assert ros1[0] is wire.SEQ and ros1[0].attr is None and all(a is b for a, b in zip(ros1[1:], model))
    elif msgtype.startswith("builtin_interfaces/"):
        assert [(f.attr, f.type) for f in ros1] == [
            ("sec", "int32" if "Duration" in msgtype else "uint32"),
            ("nanosec", "int32" if "Duration" in msgtype else "uint32"),
        ]
    else:
        assert ros1 is model
    pkg, _, name = msgtype.split("/")
    shipped = wire.definitions_root().joinpath(pkg, "msg", f"{name}.msg")
    if shipped.is_file():
        parsed = idl.parse_msg(shipped.read_text(encoding="utf-8"), msgtype).fields
        assert [(f.name, f.type, f.is_array, f.size) for f in parsed] == [
            (f.name, f.type, f.is_array, f.size) for f in model
        ]


def test_field_spec_attr_defaults_to_the_name() -> None:
    assert idl.FieldSpec("k", "float64", True, 9).attr == "k"
    assert idl.FieldSpec("seq", "uint32", attr=None).attr is None
    assert idl.FieldSpec("K", "float64", True, 9, attr="k").attr == "k"


def test_compiled_encoders_write_what_the_ops_write(typestore: Any) -> None:
    """Every type's encoder is one compiled function (cdr._compiled) that writes the bytes of its field ops run one
    by one, and rosbags' bytes; a string encoded once is then looked up at every start alignment (frame ids of
    different lengths before it), and a value refused late in a message is named as the ops name it."""
    rng = np.random.default_rng(11)
    for msgtype in idl.available_msgtypes():
        encode = cdr._encoder(msgtype)
        assert encode.__code__.co_filename == f"<cdr encoder of {msgtype}>", msgtype
    for frame in ("", "a", "ab", "abc", "base_link", "a", "ab"):  # the second "a", "ab": kept encodings
        state = msgs.JointControllerState(msgs.Header.at(1_500_000_001, frame), set_point=rng.random(), p=0.5)
        tf = msgs.TFMessage([_transform(frame, 0.25), _transform(frame + "x", 0.5)])
        for msg in (state, tf, msgs.Odometry(msgs.Header.at(3, frame), child_frame_id=frame * 2)):
            msgtype = msgs.msgtype_of(msg)
            data = msgs.serialize(msg)
            assert data == typestore.serialize_cdr(to_rosbags(msg, typestore), msgtype), (msgtype, frame)
            by_ops: list[Any] = [cdr.CDR_LE_HEADER]
            cdr._encoder(msgtype).__globals__["_checked"](msg, by_ops, 0)
            assert b"".join(by_ops) == data
    scan = msgs.LaserScan(msgs.Header.at(0, "laser"), range_max="far")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"sensor_msgs/msg/LaserScan: field 'range_max'"):
        msgs.serialize(scan)


def test_numeric_arrays_in_any_form_write_rosbags_bytes_at_every_alignment(typestore: Any) -> None:
    """The compiled encoder writes a 1-D C-ordered ndarray of a field's dtype as it is, and hands anything else to the
    field's op (cdr._numeric_array_lines): lists, other dtypes and byte orders, strided and 2-D arrays, read-only and
    empty arrays give the ops' own bytes and rosbags', after names and frame ids of every length (every start
    alignment); a fixed-size array of the wrong length is still named."""
    values = np.random.default_rng(5).normal(size=36)
    forms: list[Callable[[np.ndarray], Any]] = [
        lambda a: a.copy(),
        lambda a: a.tolist(),
        lambda a: a.astype(np.float32),
        lambda a: a.astype(">f8"),
        lambda a: np.repeat(a, 2)[::2],  # strided
        lambda a: a.reshape(-1, 1),  # 2-D
        lambda a: np.lib.stride_tricks.as_strided(a, writeable=False),  # read-only
        lambda a: a[:0],  # empty
    ]
    checked = 0
    for names in ([], ["a"], ["ab"], ["abc", "d"], ["wheel_joint"]):
        frame = "f" * len(names)
        for form in forms:
            n = len(names) or 3
            joint = msgs.JointState(msgs.Header.at(7, frame), list(names), form(values[:n]), form(values[n:2 * n]),
                                    form(values[:1]))  # fmt: skip
            scan = msgs.LaserScan(msgs.Header.at(9, frame), ranges=form(values[:5]), intensities=form(values[5:7]))
            pose = msgs.PoseWithCovariance(covariance=form(values))
            odom = msgs.Odometry(msgs.Header.at(11, frame), child_frame_id=frame * 2, pose=pose)
            camera = msgs.CameraInfo(msgs.Header.at(13, frame), d=form(values[: len(names)]), k=form(values[:9]))
            for msg in (joint, scan, odom, camera):  # a camera's k: 9 numbers after d's count (every alignment)
                msgtype = msgs.msgtype_of(msg)
                if np.size(form(values)) != 36 and msg in (odom, camera):
                    field = "pose.covariance" if msg is odom else "k"
                    with pytest.raises(ValueError, match=rf"{msgtype}: field '{field}'"):
                        msgs.serialize(msg)
                    continue
                data = msgs.serialize(msg)
                by_ops: list[Any] = [cdr.CDR_LE_HEADER]
                cdr._encoder(msgtype).__globals__["_checked"](msg, by_ops, 0)
                assert b"".join(by_ops) == data
                assert data == typestore.serialize_cdr(to_rosbags(_as_arrays(msg), typestore), msgtype), msgtype
                checked += 1
    assert checked == 5 * (4 * 8 - 2)  # an empty covariance (36 numbers) or k (9) is refused


def _as_arrays(msg: Any) -> Any:
    """`msg` with its numeric array fields as 1-D arrays of the field's dtype, as rosbags takes them (in place)."""
    for spec in idl.get_spec(msg.__msgtype__).fields:
        value = getattr(msg, spec.name)
        if isinstance(value, Message):
            _as_arrays(value)
        elif spec.is_array and spec.type in DTYPES and spec.type not in ("uint8", "byte", "char", "string"):
            setattr(msg, spec.name, np.ascontiguousarray(value, DTYPES[spec.type]).reshape(-1))
    return msg
