"""Drivers: nodes that publish AckermannDriveStamped commands on a mux input."""

from racecar_sim.drivers.constant import ConstantCommand

__all__ = ["ConstantCommand"]
