"""Control: ros_control-style joint controllers (as MuJoCo actuators), servo_commands and the command mux."""
