"""hector's GPS in a user's xacro: NavSatFix and its velocity as hector_gazebo_plugins/src/gazebo_ros_gps.cpp computes
them, checked against geodesy: the car driven 10 m north moves the latitude by that distance over the WGS 84 meridian
radius at the reference latitude (the reference's metres per degree), to 1e-7 degrees; turned by <referenceHeading>
90, the same drive goes east and moves the longitude by the parallel's metres per degree instead."""

from __future__ import annotations

import math

import pytest

from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs.sensor_msgs import NavSatFix, NavSatStatus
from racecar_sim.worlds import Spawn

LAT0, LON0, ALT0 = 42.3601, -71.0942, 10.0
A, F = 6378137.0, 1 / 298.257223563  # WGS 84: semi-major axis, flattening
E2 = F * (2 - F)


def metres_per_degree_north(latitude: float) -> float:
    """The meridian's radius of curvature M = a (1 - e^2) / (1 - e^2 sin^2 phi)^(3/2), per degree."""
    s = math.sin(math.radians(latitude))
    return A * (1 - E2) / (1 - E2 * s * s) ** 1.5 * math.pi / 180


def metres_per_degree_east(latitude: float) -> float:
    """The parallel's radius N cos phi, N = a / sqrt(1 - e^2 sin^2 phi), per degree."""
    s = math.sin(math.radians(latitude))
    return A / math.sqrt(1 - E2 * s * s) * math.cos(math.radians(latitude)) * math.pi / 180


def _gps(name: str, heading: float, extra: str = "") -> str:
    return f"""
  <gazebo>
    <plugin name="{name}" filename="libhector_gazebo_ros_gps.so">
      <updateRate>10</updateRate><bodyName>base_link</bodyName><frameId>gps_link</frameId>
      <topicName>{name}/fix</topicName><velocityTopicName>{name}/fix_velocity</velocityTopicName>
      <referenceLatitude>{LAT0}</referenceLatitude><referenceLongitude>{LON0}</referenceLongitude>
      <referenceHeading>{heading}</referenceHeading><referenceAltitude>{ALT0}</referenceAltitude>{extra}
    </plugin>
  </gazebo>"""


USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  {_gps("gps", 0)}
  {_gps("gps_east", 90, "<status>2</status><service>1</service><gaussianNoise>0.5</gaussianNoise>")}
</robot>
"""


def test_ten_metres_north_and_east(tmp_path):
    path = tmp_path / "gps.xacro"
    path.write_text(USER_XACRO)
    truth: dict[tuple[str, int], tuple[list[float], list[float]]] = {}
    with Simulator(world="empty", xacro=path, camera=False, lidar=False, seed=3, spawn=Spawn(0, 0, 0.05, 0)) as sim:
        state = sim.car.state
        root = sim.model.joint("root").dofadr[0]

        def keep(topic: str):
            def on_fix(msg: NavSatFix) -> None:  # the car's state when the fix was taken: the end of the last step
                stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                truth[(topic, stamp)] = (state.base_pose()[0].tolist(), sim.data.qvel[root : root + 3].tolist())
                fixes.setdefault(topic, []).append(msg)

            return on_fix

        fixes: dict[str, list[NavSatFix]] = {}
        velocities = []
        sim.subscribe("/gps/fix", keep("/gps/fix"))
        sim.subscribe("/gps_east/fix", keep("/gps_east/fix"))
        sim.subscribe("/gps/fix_velocity", velocities.append)
        sim.run_until(1.0)
        ConstantCommand(sim.bus, sim.scheduler, 2.0, 0.0)
        while state.base_pose()[0][0] < 11.0 and sim.time < 20.0:
            sim.run_for(0.5)
    north = fixes["/gps/fix"]
    first = next(m for m in north if m.header.stamp.sec >= 1)
    last = north[-1]

    def where(topic: str, msg: NavSatFix) -> tuple[list[float], list[float]]:
        return truth[(topic, msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)]

    (x0, y0, _), _ = where("/gps/fix", first)
    (x1, y1, z1), v1 = where("/gps/fix", last)
    assert x1 - x0 > 10.0 and abs(y1 - y0) < 0.5  # driven (about) 10 m north
    assert last.latitude - first.latitude == pytest.approx((x1 - x0) / metres_per_degree_north(LAT0), abs=1e-7)
    # hector's world is north-west-up: +y is west, so the longitude falls
    assert last.longitude - first.longitude == pytest.approx(-(y1 - y0) / metres_per_degree_east(LAT0), abs=1e-7)
    assert last.altitude == pytest.approx(ALT0 + z1, abs=1e-9)
    assert (last.header.frame_id, last.status.status, last.status.service) == ("gps_link", NavSatStatus.STATUS_FIX, 0)
    assert last.position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    assert not last.position_covariance.any()  # no noise declared
    velocity = velocities[-1]
    assert velocity.header.stamp == last.header.stamp and velocity.vector.x == pytest.approx(v1[0], abs=1e-9)
    assert velocity.vector.x == pytest.approx(2.0, abs=0.2)
    # <referenceHeading> 90: the same drive is east; the fix is noisy (gaussianNoise 0.5 m), so compare loosely
    east = fixes["/gps_east/fix"]
    start, end = (next(m for m in east if m.header.stamp.sec >= 1), east[-1])
    (ex0, _, _), _ = where("/gps_east/fix", start)
    (ex1, _, _), _ = where("/gps_east/fix", end)
    moved = (end.longitude - start.longitude) * metres_per_degree_east(LAT0)
    assert moved == pytest.approx(ex1 - ex0, abs=2.5) and moved > 8.0
    assert abs(end.latitude - start.latitude) * metres_per_degree_north(LAT0) < 2.5
    assert (end.status.status, end.status.service) == (NavSatStatus.STATUS_GBAS_FIX, NavSatStatus.SERVICE_GPS)
    assert end.position_covariance[0] == end.position_covariance[4] == end.position_covariance[8] == 0.25
    assert len(north) == pytest.approx(10 * sim.time, abs=1)  # <updateRate> 10 Hz
