"""roslaunch files in the sim: read the XML into a plan, map the original stack's nodes onto the sim's, run it.

plan = load_launch("racecar.launch", {"world_name": "racecar_tunnel"})   # xml_loader: the parameter tree, nodes
setup = map_plan(plan)                                                    # mapping: world, cars, drivers, the rest
with LaunchRun(setup) as run: run.sim.run_until(2.0)                      # runner: a Simulator from the setup
"""

from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.mapping import SimSetup, map_plan
from racecar_sim.launch.plan import LaunchPlan, NodeSpec
from racecar_sim.launch.ros_only import RosOnlyLaunch, has_car
from racecar_sim.launch.runner import LaunchRun
from racecar_sim.launch.xml_loader import load_launch

__all__ = [
    "LaunchError",
    "LaunchPlan",
    "LaunchRun",
    "NodeSpec",
    "RosOnlyLaunch",
    "SimSetup",
    "has_car",
    "load_launch",
    "map_plan",
]
