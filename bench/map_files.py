"""Writing a ROS map_server map (PGM + YAML) for the benches' generated worlds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image


def write_map(folder: Path, name: str, occupied: np.ndarray, resolution: float, origin: tuple[float, float]) -> Path:
    """`name`.pgm and `name`.yaml in `folder` for a boolean grid (True: occupied; row 0 is the top of the image, as
    map_server reads it); the YAML's path."""
    Image.fromarray(np.where(occupied, 0, 254).astype(np.uint8)).save(folder / f"{name}.pgm")
    path = folder / f"{name}.yaml"
    path.write_text(
        f"image: {name}.pgm\nresolution: {resolution}\norigin: [{origin[0]}, {origin[1]}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return path
