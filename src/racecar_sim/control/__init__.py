"""Control: gazebo_ros_control (ros_control joint controllers as MuJoCo actuators, joint_state_controller, the
controller_manager), servo_commands and its law, the ackermann_cmd_mux chain, driving profiles, keyboard teleop."""
