"""What a car senses and reports, each a node built from the description's <sensor> or <plugin> block (through
runtime/plugins.py) or from the launch: lasers (lidar.py, raycast/), cameras (camera.py), depth cameras, IMUs,
p3d ground truth, robot_state_publisher (TF) and odometry."""
