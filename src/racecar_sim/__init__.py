"""racecar-sim: the MIT RACECAR simulator on MuJoCo, without ROS or Gazebo.

    from racecar_sim import Simulator
    sim = Simulator(world="empty", profile="seed", seed=0)
"""

__version__ = "0.1.0"

from racecar_sim.sensors.gl import guard_mujoco_import  # noqa: E402

guard_mujoco_import()  # before anything imports mujoco: a MUJOCO_GL backend without its library must not break it

from racecar_sim.runtime import Car, Simulator  # noqa: E402
from racecar_sim.worlds import Spawn  # noqa: E402

__all__ = ["Car", "Simulator", "Spawn", "__version__"]
