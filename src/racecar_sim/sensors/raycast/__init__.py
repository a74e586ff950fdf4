"""Ray casting for planar range finders: an exact 2-D caster over wall footprints, MuJoCo's 3-D casts where
2-D is not exact, and the RayCaster that picks per beam (see caster.py)."""

from racecar_sim.sensors.raycast.caster import MODES, RayCaster
from racecar_sim.sensors.raycast.fan import Fan, ScanFrame

__all__ = ["MODES", "Fan", "RayCaster", "ScanFrame"]
