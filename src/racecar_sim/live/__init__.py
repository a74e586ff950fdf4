"""Live views of a running sim: the MuJoCo viewer window and the Foxglove WebSocket server."""
