"""racecar-sim: the MIT RACECAR simulator on MuJoCo, without ROS or Gazebo.

    from racecar_sim import Simulator
    sim = Simulator(world="empty", profile="seed", seed=0)
"""

__version__ = "0.1.0"

from racecar_sim.runtime import Simulator  # noqa: E402

__all__ = ["Simulator", "__version__"]
