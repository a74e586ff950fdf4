"""The live view of a running sim: the MuJoCo viewer window (viewer.py), following a car, WASD driving it."""
