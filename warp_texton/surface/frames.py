"""Directions on surfaces: the frame rule, up axes, and the checks of the (N, 3)
arrays and 3-vectors that surface noise, meshes and renders take.

A point of a surface without UVs needs a tangent frame (u1, u2, n) to lay the
texton on its tangent plane (CGF §6). Unless the caller gives tangents, u1
follows one continuous rule (:func:`tangent_frames`, the same as
``kernels/surface_points.py:tangent_frame``) built from two world directions, ``up``
and ``side``; :func:`up_rotation` turns the Z-up defaults to a world whose up
axis is another one (glTF is Y-up).
"""

from __future__ import annotations

import numpy as np

from ..core.checks import as_real_array
from ..core.errors import TextonError

#: The frame rule's directions: u1 follows `up` projected on the tangent plane,
#: blended towards `side` where the normal is close to `up`.
UP = (0.0, 0.0, 1.0)
SIDE = (1.0, 0.0, 0.0)
#: Names ``up`` takes besides a 3-vector: the world axis that points up.
UP_NAMES = ("x", "y", "z")


def as_points(a, name: str) -> np.ndarray:
    """A finite (N, 3) float64 array (points, normals or tangents)."""
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be an array of shape (N, 3) of numbers") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise TextonError(f"{name} must have shape (N, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise TextonError(f"{name} contain {int((~np.isfinite(arr)).sum())} NaN or infinite values")
    return arr


def check_lengths(length: np.ndarray, name: str) -> None:
    """Refuse rows of zero length (``name`` is a plural: "normals")."""
    bad = np.flatnonzero(length < 1e-12)
    if bad.size:
        raise TextonError(f"{name}[{bad[0]}] has zero length ({bad.size} such rows); every {name[:-1]} must be non-zero")


def unit_rows(v: np.ndarray, name: str) -> np.ndarray:
    """The rows of ``v`` divided by their lengths; zero rows are refused."""
    # np.linalg.norm(v, axis=1), bit for bit (the same sums in the same order), faster
    length = np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])
    check_lengths(length, name)
    return v / length[:, None]


def as_point(v, name: str) -> np.ndarray:
    """A finite 3-vector of numbers."""
    p = as_real_array(v, name, "a point (x, y, z) of numbers").reshape(-1)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise TextonError(f"{name} must be a point (x, y, z) of finite numbers, got {v!r:.60}")
    return p


def as_direction(v, name: str) -> np.ndarray:
    """A unit 3-vector from a non-zero triple of finite numbers (strings are not numbers)."""
    try:
        d = as_real_array(v, name, "a non-zero 3-vector").reshape(-1)
    except TextonError:
        raise TextonError(f"{name} must be a non-zero 3-vector of numbers, got {v!r:.60}") from None
    if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) < 1e-12:
        raise TextonError(f"{name} must be a non-zero 3-vector, got {v!r:.60}")
    return d / np.linalg.norm(d)


def tangent_frames(normals, *, up=UP, side=None) -> tuple[np.ndarray, np.ndarray]:
    """The frame rule used when no tangents are given: returns (u1, u2).

    The frames :func:`surface_noise`, :func:`texture_mesh`,
    :func:`render_mesh` and :func:`bake_mesh` use when no tangents are given:
    u1 is the direction of v(n) = P_n(up) + ⟨up, n⟩⁴ P_n(side), with P_n the
    projection on the plane orthogonal to n, and u2 = n × u1. On a plane
    facing ``up`` the frame is (side, up × side); on walls u1 points ``up``.
    The kernels implement the same rule (kernels/surface_points.py:tangent_frame).

    Parameters
    ----------
    normals : array (N, 3)
        Normals; normalised here, so any non-zero length.
    up : str or (x, y, z)
        The world's up direction: a non-zero vector or an axis name, "x",
        "y" or "z"; default z.
    side : (x, y, z), optional
        The direction u1 takes where the normal is ``up``; default the
        world's right for that up axis (x, or y when up is x).

    Returns
    -------
    u1, u2 : float64 arrays (N, 3)
        Unit vectors: the directions of the texton's x and y axes on the
        tangent plane.

    Raises
    ------
    TextonError
        For ``normals`` that are not a finite numeric (N, 3) array, a zero
        normal, an ``up`` that is zero or an unknown name, and a zero
        ``side``.

    Notes
    -----
    v is continuous in n and vanishes only at isolated normals (where it
    does, P_n(side) stands in), so frames vary continuously wherever the
    normals do, except around two normals, ≈ ±(0.495, 0, 0.869) for the
    default directions, where any rule on a closed surface must break (the
    hairy-ball theorem). The rule's derivation is in docs/model.md §12, "The
    tangent frame".

    References
    ----------
    CGF §6 (a tangent frame at every surface point).

    Examples
    --------
    A floor, a ceiling and two walls, Z up:

    >>> import numpy as np
    >>> from warp_texton import tangent_frames
    >>> n = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0]], dtype=float)
    >>> u1, u2 = tangent_frames(n)
    >>> u1.round(3).tolist()
    [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    >>> u2.round(3).tolist()
    [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]]

    Another convention, Y up: now the first normal faces a wall, and u1
    points up there:

    >>> u1, u2 = tangent_frames(n, up="y")
    >>> u1.round(3).tolist()
    [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
    """
    n = unit_rows(as_points(normals, "normals"), "normals")
    a, b = frame_rule(up, side)
    ca = n @ a
    v = (a - n * ca[:, None]) + (b - n * (n @ b)[:, None]) * (ca ** 4)[:, None]
    small = np.linalg.norm(v, axis=1) < 1e-6
    if small.any():
        v[small] = b - n[small] * (n[small] @ b)[:, None]
        still = np.linalg.norm(v, axis=1) < 1e-6
        v[still] = np.cross(n[still], a)
    u1 = v / np.linalg.norm(v, axis=1)[:, None]
    return u1, np.cross(n, u1)


def up_vector(up) -> np.ndarray:
    """``up`` as a unit 3-vector: "x", "y", "z" name a world axis; a 3-vector is normalised."""
    if isinstance(up, str):
        name = up.lower()
        if name not in UP_NAMES:
            raise TextonError(f"up must be one of x, y, z or a 3-vector, got {up!r}")
        return np.eye(3)[UP_NAMES.index(name)]
    return as_direction(up, "up")


def up_rotation(up) -> np.ndarray:
    """The rotation R (world = R · z-up frame) that takes the Z-up frame of the
    defaults (frame rule, view, light) to a world whose up is ``up``.

    R's columns are (b, a × b, a): a = ``up``, b = the x axis made orthogonal to
    a (the y axis when a is along x). So "z" is the identity and "y" is glTF's
    frame (+Z, the front, is the Z-up frame's −Y; +X stays to the right).

    >>> up_rotation("y").astype(int).tolist()
    [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    """
    a = up_vector(up)
    b = np.array([1.0, 0.0, 0.0]) - a * a[0]
    if np.linalg.norm(b) < 1e-3:
        b = np.array([0.0, 1.0, 0.0]) - a * a[1]
    b /= np.linalg.norm(b)
    return np.stack([b, np.cross(a, b), a], axis=1)


def frame_rule(up, side=None) -> tuple[np.ndarray, np.ndarray]:
    """(up, side) vectors of the frame rule: ``side`` defaults to the world's
    "right" for this up axis (x, or y when up is along x)."""
    if side is None:
        r = up_rotation(up)
        return r[:, 2].copy(), r[:, 0].copy()
    return up_vector(up), as_direction(side, "side")

