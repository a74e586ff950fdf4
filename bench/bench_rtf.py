"""Real-time factor of the full pipeline - sensors off, lidar on, lidar + camera - against bare MuJoCo stepping:
`python bench/bench_rtf.py`.

Same as `racecar-sim bench`; extra arguments are passed through (e.g. --physics gazebo --duration 60).
"""

import sys

from racecar_sim.cli.main import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
