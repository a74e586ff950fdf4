"""Every bus topic, live, over the Foxglove WebSocket protocol (bridge.py), for Foxglove and Lichtblick."""
