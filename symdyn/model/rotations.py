"""Rotations from quaternions, in one place: the one formula every reader, the floating base,
the pictures and the random models use.

Part of the model stage.  A quaternion is (x, y, z, w) — Pinocchio's and symdyn's order, w last
— unless `order="wxyz"` says MuJoCo's (w first).  `quaternion_matrix` takes unit quaternions as
they are (it normalises nothing: a caller that accepts other norms says so and divides first).
"""

from __future__ import annotations

import numpy as np

__all__ = ["quaternion_matrix", "quaternion_entries"]


def quaternion_matrix(quat, order: str = "xyzw") -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) given in `order` ("xyzw": w last,
    as symdyn's and Pinocchio's q; "wxyz": w first, as MuJoCo's qpos and body_quat).

    Raises:
        ValueError: an order that is neither "xyzw" nor "wxyz".
    """
    quat = np.asarray(quat, dtype=float)
    if order == "xyzw":
        x, y, z, w = (quat[..., k] for k in range(4))
    elif order == "wxyz":
        w, x, y, z = (quat[..., k] for k in range(4))
    else:
        raise ValueError(f"quaternion order {order!r}: expected 'xyzw' (w last) or 'wxyz' (w first)")
    R = np.empty(quat.shape[:-1] + (3, 3))
    for k, entry in enumerate(quaternion_entries(x, y, z, w)):
        R[..., k // 3, k % 3] = entry
    return R


def quaternion_entries(x, y, z, w, k=2) -> tuple:
    """The nine entries, row by row, of the rotation of the quaternion (x, y, z, w): numbers,
    arrays or symbols (the generated contact anchors' and floating bases' use the last).  k = 2
    for a unit quaternion; k = 2/|q|² reads any non-zero one by its direction."""
    return (
        *(1 - k * (y * y + z * z), k * (x * y - z * w), k * (x * z + y * w)),
        *(k * (x * y + z * w), 1 - k * (x * x + z * z), k * (y * z - x * w)),
        *(k * (x * z - y * w), k * (y * z + x * w), 1 - k * (x * x + y * y)),
    )
