"""What the car reports: joint states, TF (robot_state_publisher), odometry; the lidar and camera later."""
