"""Bridges from the sim's bus to other middleware, each taking the bus and the clock: taps going out, a thread-safe
inbox coming in, drained at sim events. foxglove/: the Foxglove WebSocket server; ros1/: a ROS 1 graph through rospy."""
