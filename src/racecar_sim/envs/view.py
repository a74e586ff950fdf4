"""An env's render(): the chase camera's frame, or the MuJoCo viewer window."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

if TYPE_CHECKING:
    from racecar_sim.envs.chase_camera import ChaseCamera
    from racecar_sim.runtime import Simulator
    from racecar_sim.viz.viewer import CarViewer


class EnvView:
    """What an env's render() shows: the chase camera's frame behind the first car ("rgb_array"), or the viewer
    window with every car ("human", where there is a display; headless it warns once and shows nothing).

    Opened on a Simulator; `open()` again after the env rebuilds it for another world.
    """

    def __init__(self, render_mode: str | None, sim: Simulator) -> None:
        self.render_mode = render_mode
        self._chase: ChaseCamera | None = None
        self._viewer: CarViewer | Literal[False] | None = None  # False: no window could open
        self.open(sim)

    def open(self, sim: Simulator) -> None:
        """Follow `sim` (its first car for the chase camera): RenderingError (one line) without headless GL."""
        self.close()
        self.sim = sim
        if self.render_mode == "rgb_array":
            from racecar_sim.envs.chase_camera import (
                ChaseCamera,  # GL only for an env that renders
            )

            self._chase = ChaseCamera(sim.model, sim.data, sim.cars[0].state.body_id)

    def render(self) -> np.ndarray | None:
        """The chase camera's frame (rgb_array), or None after refreshing the viewer window (human)."""
        if self._chase is not None:
            return self._chase.frame()
        if self.render_mode == "human":
            if self._viewer is None:
                from racecar_sim.viz.viewer import CarViewer

                roots = [car.names.mj(car.robot.root) for car in self.sim.cars]
                self._viewer = CarViewer.open(self.sim.model, self.sim.data, roots, "render_mode='human'") or False
            if self._viewer:
                self._viewer.sync(None)
        return None

    def close(self) -> None:
        """Free the chase camera's GL objects and close the window."""
        if self._chase is not None:
            self._chase.close()
            self._chase = None
        if self._viewer:
            self._viewer.close()
        self._viewer = None
