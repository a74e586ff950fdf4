"""ROS 2-shaped message classes, their ``.msg`` definitions and CDR serialization.

Field names follow ROS 2 exactly (``msg.header.stamp.sec``, ``scan.ranges``,
``cmd.drive.steering_angle``), numeric arrays are numpy arrays, and
``serialize``/``deserialize`` produce and read the bytes rosbag2 stores.
"""

from racecar_sim.msgs.ackermann_msgs import AckermannDrive, AckermannDriveStamped
from racecar_sim.msgs.builtin_interfaces import Duration, Time
from racecar_sim.msgs.cdr import deserialize, serialize
from racecar_sim.msgs.control_msgs import JointControllerState
from racecar_sim.msgs.controller_manager_msgs import ControllerState, HardwareInterfaceResources
from racecar_sim.msgs.gazebo_msgs import LinkStates, ModelState, ModelStates
from racecar_sim.msgs.geometry_msgs import (
    Point,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from racecar_sim.msgs.idl import schema_text
from racecar_sim.msgs.nav_msgs import MapMetaData, OccupancyGrid, Odometry
from racecar_sim.msgs.registry import message_class, msgtype_of
from racecar_sim.msgs.rosgraph_msgs import Clock
from racecar_sim.msgs.sensor_msgs import (
    CameraInfo,
    Image,
    Imu,
    JointState,
    Joy,
    LaserScan,
    PointCloud2,
    PointField,
    RegionOfInterest,
)
from racecar_sim.msgs.std_msgs import Float64, Header, Int8, String
from racecar_sim.msgs.tf2_msgs import TFMessage

__all__ = [
    "AckermannDrive",
    "AckermannDriveStamped",
    "CameraInfo",
    "Clock",
    "ControllerState",
    "Duration",
    "Float64",
    "Header",
    "HardwareInterfaceResources",
    "Image",
    "Imu",
    "Int8",
    "JointControllerState",
    "JointState",
    "Joy",
    "LaserScan",
    "LinkStates",
    "MapMetaData",
    "ModelState",
    "ModelStates",
    "OccupancyGrid",
    "Odometry",
    "Point",
    "PointCloud2",
    "PointField",
    "Pose",
    "PoseStamped",
    "PoseWithCovariance",
    "PoseWithCovarianceStamped",
    "Quaternion",
    "RegionOfInterest",
    "String",
    "TFMessage",
    "Time",
    "Transform",
    "TransformStamped",
    "Twist",
    "TwistWithCovariance",
    "Vector3",
    "deserialize",
    "message_class",
    "msgtype_of",
    "schema_text",
    "serialize",
]
