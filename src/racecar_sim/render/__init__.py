"""Offscreen OpenGL for the cameras and the env's chase camera: the headless context on its own thread (gl.py: EGL or
OSMesa, probed without crashing, egl_probe.py) and MuJoCo scenes drawn into reused buffers (offscreen.py)."""
