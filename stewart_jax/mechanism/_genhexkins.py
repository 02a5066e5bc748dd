"""Export a strut hexapod to LinuxCNC's ``genhexkins`` kinematics module.

``genhexkins`` (LinuxCNC, generalised hexapod kinematics) models six struts between base
joints ``b_i`` given in the base (world) frame and platform joints ``a_i`` given in the platform
frame; its inverse kinematics is the strut length ``|R·a_i + pos − b_i|`` with
``R = Rz(C)·Ry(B)·Rx(A)`` (roll A, pitch B, yaw C, in degrees) and ``pos = (X, Y, Z)`` the
platform frame's origin in the world frame. Its joint positions are strut lengths, and the
joint geometry is set with one HAL setting per coordinate, ``genhexkins.base.N.x`` …
``genhexkins.platform.N.z`` for ``N = 0…5``.

For a :class:`~stewart_jax.mechanism.UPSMechanism` the base joints are ``base`` (frame B) and the
platform joints ``platform`` (frame A, whose origin is the commanded pivot), so a library pose
``[dx, dy, dz, φ, θ, ψ]`` is the controller's ``X, Y, Z = d + v0`` and ``A, B, C = φ, θ, ψ`` in
degrees, and a strut's ``genhexkins`` joint value is ``lengths0_i + q_i``. Both are written as
comment lines, with the full-precision (``repr``) values, so that a calibrated hexapod can be
loaded by a real controller.
"""

from __future__ import annotations

import numpy as np

from ._abstract import AbstractMechanism
from ._ups import UPSMechanism

SINGULAR_CONDITION = 1e3
"""The largest condition number of the strut Jacobian at the zero pose that an export accepts
(rotation columns in mm per rad divided by the platform radius, so that every column is a
dimensionless strut-length change; the presets have 1.7–7.2). Beyond it a strut error of 1 µm
moves the pose by about a millimetre, and LinuxCNC's iterative forward kinematics may not
converge."""
_POSE_AXES = ("x", "y", "z", "rx", "ry", "rz")


def check_not_singular(mechanism: UPSMechanism) -> None:
    """Refuse a geometry whose struts do not hold the platform at its zero pose (a ``ValueError``
    naming the condition number and the pose direction the struts hold least)."""
    import jax.numpy as jnp

    jac = np.asarray(mechanism.ik_and_jacobian(jnp.zeros((1, 6)))[2][0], np.float64)
    radius = float(np.max(np.linalg.norm(np.asarray(mechanism.platform, np.float64), axis=1)))
    scaled = jac / np.array([1.0] * 3 + [max(radius, 1e-300)] * 3)
    if not np.all(np.isfinite(scaled)):
        raise ValueError("the strut Jacobian at the zero pose is not finite: the geometry cannot be exported")
    _, s, vt = np.linalg.svd(scaled)
    condition = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    if condition > SINGULAR_CONDITION:
        weak = vt[-1] / np.max(np.abs(vt[-1]))
        direction = " ".join(f"{c:+.2f}·{a}" for c, a in zip(weak, _POSE_AXES, strict=True) if abs(c) >= 0.05)
        raise ValueError(
            f"the geometry is (near-)singular at its zero pose: the strut Jacobian's condition number is "
            f"{condition:.3g} (rotations scaled by the platform radius {radius:.4g} mm; the presets have 1.7–7.2, "
            f"the export accepts at most {SINGULAR_CONDITION:g}). The struts barely hold the pose direction "
            f"{direction}, so a strut error of 1 µm would move the platform by about {condition * 1e-3:.3g} mm and "
            "LinuxCNC's forward kinematics could fail to converge: check the joint coordinates")


def to_genhexkins(mechanism: AbstractMechanism) -> str:
    """The LinuxCNC ``genhexkins`` settings (HAL ``setp`` lines, mm) of a 6-UPS strut hexapod.

    Lines ``setp genhexkins.base.N.{x,y,z} VALUE`` then ``setp genhexkins.platform.N.{x,y,z}
    VALUE`` for ``N = 0…5`` (strut ``N + 1`` of the library), preceded by ``#`` comment lines
    stating the zero-reading strut lengths (``lengths0``), ``v0`` and the pose convention.
    Raises ``TypeError`` for any other family (e.g. a 6-PSS: genhexkins models struts, not
    sliders carrying fixed rods), and ``ValueError`` for a geometry near a singularity at its zero
    pose (:func:`check_not_singular`), which LinuxCNC could not drive.
    """
    if not isinstance(mechanism, UPSMechanism):
        family = mechanism.family if isinstance(mechanism, AbstractMechanism) else type(mechanism).__name__
        raise TypeError(
            f"genhexkins models struts (6-UPS strut hexapods); a {family!r} mechanism cannot be "
            "exported to it"
        )
    base = np.asarray(mechanism.base, dtype=np.float64)
    platform = np.asarray(mechanism.platform, dtype=np.float64)
    if base.shape != (6, 3) or platform.shape != (6, 3):
        raise ValueError(f"to_genhexkins exports one mechanism, not a batch (base shape {base.shape})")
    check_not_singular(mechanism)
    v0 = np.asarray(mechanism.v0, dtype=np.float64)
    lengths0 = np.asarray(mechanism.lengths0, dtype=np.float64)
    lines = [
        "# LinuxCNC genhexkins settings of a 6-UPS strut hexapod, written by stewart_jax (lengths in mm)",
        "# base.N: strut N+1's base joint in the base (world) frame B;",
        "# platform.N: its platform joint in the platform frame A (origin at the commanded pivot)",
        "# pose: X Y Z = d + v0 (mm), A B C = phi theta psi (degrees), R = Rz(C)*Ry(B)*Rx(A)",
        f"# v0 (A's origin in B at the zero pose, mm): {' '.join(repr(float(x)) for x in v0)}",
        "# strut lengths at zero reading (joint value = length0 + reading, mm):",
        "# lengths0: " + " ".join(repr(float(x)) for x in lengths0),
    ]
    for side, pts in (("base", base), ("platform", platform)):
        for n in range(6):
            for k, axis in enumerate("xyz"):
                lines.append(f"setp genhexkins.{side}.{n}.{axis} {float(pts[n, k])!r}")
    return "\n".join(lines) + "\n"
