"""Bridges from the sim's bus to other middleware (ros1: a ROS 1 graph through rospy)."""
