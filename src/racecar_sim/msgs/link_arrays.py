"""The moving links' poses and twists of /gazebo/link_states and model_states, from MuJoCo's state arrays.

One piece of arithmetic, used where the simulation makes the messages (GazeboApi.link_arrays, on the live MjData) and
where a writer process packs them (the same arrays' bytes, handed over as they are): the numbers are the same bits
either way, and the simulation's tick does no per-link work when only a recorder takes the topics.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

_XYZW = np.array([1, 2, 3, 0])  # MuJoCo's quaternion (w x y z) in ROS's order
_NEXT, _AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])  # a cross product's components: a[next] b[after] - ...

STATE_ARRAYS = ("qpos", "kin_xpos", "kin_xquat", "xpos", "subtree_com", "cvel")
"""What a row of LinkArrays.derive() holds, in order: the simulation's qpos, the posed data's xpos and xquat (kinematics
of that qpos; empty bytes where no link needs them), and the simulation's xpos, subtree_com and cvel."""


class LinkArrays:
    """The moving links' rows: free-joint links (their qpos addresses `free_qpos`, (n, 7) in ROS's pose order) first,
    then the links posed by kinematics (`posed_bodies`); `bodies` and `roots` are all of them and their root bodies,
    in that order. Pickles as its index arrays (a writer process derives the rows from a tick's arrays' bytes)."""

    def __init__(self, free_qpos: np.ndarray, posed_bodies: np.ndarray, bodies: np.ndarray, roots: np.ndarray) -> None:
        self.free_qpos, self.posed_bodies, self.bodies, self.roots = free_qpos, posed_bodies, bodies, roots
        self._last: tuple[object, tuple[np.ndarray, np.ndarray]] | None = None  # (row, its arrays): both topics' share
        self._plan: tuple[tuple[int, ...], np.ndarray, np.ndarray] | None = None  # derive()'s indexes: _plan_for()

    def of(
        self,
        qpos: np.ndarray,
        kin_xpos: np.ndarray,
        kin_xquat: np.ndarray,
        xpos: np.ndarray,
        subtree_com: np.ndarray,
        cvel: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The poses (x, y, z, qx, qy, qz, qw) and twists (vx, vy, vz, wx, wy, wz) of the moving links: free-joint
        links from qpos, the others from the posed data, and the twists as mj_objectVelocity(mjOBJ_XBODY, world frame)
        gives them, with its arithmetic (mju_transformSpatial: the body's cvel moved from its subtree's centre of mass
        to its frame's origin) for every link at once: the same bits (tests/test_recording_direct.py)."""
        bodies, posed = self.bodies, self.posed_bodies
        poses = np.empty((len(bodies), 7))
        free = len(self.free_qpos)
        poses[:free] = qpos[self.free_qpos]
        if len(posed):
            poses[free:, :3] = kin_xpos[posed]
            poses[free:, 3:] = kin_xquat[posed[:, None], _XYZW]
        body_cvel = cvel[bodies]
        offset, angular = xpos[bodies] - subtree_com[self.roots], body_cvel[:, :3]
        twists = np.empty((len(bodies), 6))
        twists[:, 3:] = angular
        # the linear velocity at the frame's origin: minus offset x angular, component by component as mju_cross
        twists[:, :3] = body_cvel[:, 3:] - (
            offset[:, _NEXT] * angular[:, _AFTER] - offset[:, _AFTER] * angular[:, _NEXT]
        )
        return poses, twists

    def derive(self, row: Sequence[bytes]) -> tuple[np.ndarray, np.ndarray]:
        """of() the arrays whose bytes `row` holds (STATE_ARRAYS, float64, C order); the last row's arrays are kept, so
        that the link and the model states of one tick derive them once.

        A writer process derives every recorded tick: of()'s two dozen small numpy operations on the row's arrays are
        done here as one gather from the row's bytes joined, of()'s arithmetic on the gathered numbers (the same
        operations on the same numbers, element by element: the same bits) and one gather into place."""
        last = self._last
        if last is not None and last[0] is row:
            return last[1]
        sizes = tuple(len(data) for data in row)
        plan = self._plan if self._plan is not None and self._plan[0] == sizes else self._plan_for(sizes)
        _, gather, order = plan
        # the copied numbers (poses, angular velocities: 10 per link), then 3n each of the linear velocity at the
        # centre of mass, offset[NEXT]'s two terms, offset[AFTER]'s two terms, angular[AFTER], angular[NEXT]
        n = len(self.bodies)
        numbers = np.frombuffer(b"".join(row), "<f8")[gather]
        linear, x_next, com_next, x_after, com_after, w_after, w_next = numbers[10 * n :].reshape(7, 3 * n)
        moved = linear - ((x_next - com_next) * w_after - (x_after - com_after) * w_next)
        flat = np.concatenate((numbers[: 10 * n], moved))[order]
        arrays = flat[: 7 * n].reshape(n, 7), flat[7 * n :].reshape(n, 6)
        self._last = (row, arrays)
        return arrays

    def _plan_for(self, sizes: tuple[int, ...]) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
        """derive()'s indexes for rows of arrays of `sizes` bytes: where of() reads each number in the row's arrays
        joined (`gather`), and where each of derive()'s results is in the copied and the computed numbers (`order`)."""
        starts = np.cumsum((0, *sizes[:-1])) // 8
        qpos, kin_xpos, kin_xquat, xpos, subtree_com, cvel = (
            np.arange(start, start + size // 8) for start, size in zip(starts, sizes)
        )
        kin_xpos, kin_xquat, xpos, subtree_com, cvel = (
            kin_xpos.reshape(-1, 3),
            kin_xquat.reshape(-1, 4),
            xpos.reshape(-1, 3),
            subtree_com.reshape(-1, 3),
            cvel.reshape(-1, 6),
        )
        bodies, posed, n = self.bodies, self.posed_bodies, len(self.bodies)
        poses = np.concatenate(
            (qpos[self.free_qpos].reshape(-1, 7), np.hstack((kin_xpos[posed], kin_xquat[posed[:, None], _XYZW])))
        )
        angular, offset_at, com_at = cvel[bodies, :3], xpos[bodies], subtree_com[self.roots]
        gather = np.concatenate(
            (
                poses.ravel(),
                angular.ravel(),
                cvel[bodies, 3:].ravel(),
                offset_at[:, _NEXT].ravel(),
                com_at[:, _NEXT].ravel(),
                offset_at[:, _AFTER].ravel(),
                com_at[:, _AFTER].ravel(),
                angular[:, _AFTER].ravel(),
                angular[:, _NEXT].ravel(),
            )
        )
        # of()'s poses (n, 7) then twists (n, 6: linear, angular), from [poses, angular, linear] as gathered
        copied_angular = 7 * n + np.arange(3 * n).reshape(n, 3)
        computed_linear = 10 * n + np.arange(3 * n).reshape(n, 3)
        order = np.concatenate((np.arange(7 * n), np.hstack((computed_linear, copied_angular)).ravel()))
        self._plan = (sizes, gather, order)
        return self._plan

    def __reduce__(self) -> tuple[type[LinkArrays], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        return LinkArrays, (self.free_qpos, self.posed_bodies, self.bodies, self.roots)
