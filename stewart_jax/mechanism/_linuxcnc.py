"""A LinuxCNC machine configuration (INI + HAL) for the ``genhexkins`` kinematics module.

``genhexkins`` (LinuxCNC, generalised hexapod kinematics, after R. Brian Register) solves the
forward kinematics by Newton–Raphson iteration started from the last pose, and at start-up from
``[TRAJ]HOME``; its joints are strut lengths and its world coordinates ``X Y Z`` the platform
frame's origin in the base frame, ``A B C`` roll, pitch and yaw in degrees with
``R = Rz(C)·Ry(B)·Rx(A)``. For a :class:`~stewart_jax.mechanism.UPSMechanism` that is the library's
pose shifted by the pivot: ``X Y Z = d + v0``. The configuration written here therefore

- puts ``[TRAJ]HOME`` at the pivot pose ``v0, 0, 0, 0`` (the iteration fails from LinuxCNC's default
  of zero, which is hundreds of millimetres from any solution on a telescope hexapod);
- gives each joint its strut length at that pose as ``HOME`` and ``lengths0 + stroke limits`` as
  ``MIN_LIMIT``/``MAX_LIMIT``;
- bounds each axis by the mechanism's workspace along that axis from the pivot pose
  (:func:`~stewart_jax.mechanism.max_travel`), in the controller's shifted coordinates;
- names LinuxCNC's I/O controller (``[EMCIO]EMCIO = io``: without it LinuxCNC 2.9 starts but never
  leaves E-stop) and an empty tool table;
- sets millimetres and degrees, and holds ``tool-offset``, ``spindle-offset`` and ``screw-lead`` at 0:
  ``genhexkins`` adds the first two to the ``z`` of every platform and base joint, which moves the
  rotation centre off the calibrated pivot, and the third corrects for screw rotation that a
  calibrated 6-UPS geometry does not model.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._abstract import AbstractMechanism
from ._genhexkins import to_genhexkins
from ._ups import UPSMechanism

# Placeholders the geometry cannot know; the INI says so next to each.
_JOINT_MAX_VELOCITY_MM_S = 1.0
_JOINT_MAX_ACCELERATION_MM_S2 = 10.0
_ANGULAR_MAX_VELOCITY_DEG_S = 0.5
_MAX_ANGLE_RAD = 0.5


class LinuxCNCConfig(NamedTuple):
    """The files of a LinuxCNC ``genhexkins`` machine configuration.

    - ``ini``: the INI file's text (``[KINS]``, ``[TRAJ]``, ``[JOINT_0..5]``, ``[AXIS_X..C]``, …).
    - ``hal``: the HAL file's text (``loadrt``, the 36 ``setp genhexkins.*`` joint coordinates,
      the offsets held at 0), ending by sourcing the user's HAL file ``NAME_user.hal``.
    - ``tool_table``: the tool table's text (no tools: one comment line).
    - ``user_hal``: the user's HAL file as first written (a simulated joint loop to replace with
      the machine's drives); the export writes it only where it is missing, so a re-export keeps
      the user's wiring.
    - ``home``: ``Float[ndarray, "6"]``, ``[TRAJ]HOME`` (mm, degrees): ``v0`` and zero angles.
    - ``joint_home_mm``: ``Float[ndarray, "6"]``, the strut lengths at ``home``.
    - ``joint_limits_mm``: ``Float[ndarray, "6 2"]``, ``lengths0`` + the stroke limits.
    - ``axis_limits``: ``Float[ndarray, "6 2"]``, min and max of X Y Z (mm) and A B C (degrees).
    """

    ini: str
    hal: str
    tool_table: str
    user_hal: str
    home: np.ndarray
    joint_home_mm: np.ndarray
    joint_limits_mm: np.ndarray
    axis_limits: np.ndarray


def to_linuxcnc(
    mechanism: AbstractMechanism,
    *,
    stroke_limits_mm: tuple[float, float] | None = None,
    name: str = "hexapod",
) -> LinuxCNCConfig:
    """A LinuxCNC configuration that starts ``genhexkins`` on this 6-UPS strut hexapod.

    ``stroke_limits_mm`` (``(min, max)`` of the reading, mm) is used when the mechanism has no
    ``stroke_limits`` of its own; with neither, a ``ValueError`` says how to give them (joint
    limits cannot be guessed). ``name`` names the HAL file (``NAME.hal``) that the INI loads.
    Raises ``TypeError`` for a family other than 6-UPS, as :func:`to_genhexkins` does.
    """
    from ._workspace import max_travel

    hal_setp = to_genhexkins(mechanism)
    assert isinstance(mechanism, UPSMechanism)
    if mechanism.stroke_limits is not None and stroke_limits_mm is not None:
        own = [tuple(map(float, lim)) for lim in np.atleast_2d(np.asarray(mechanism.stroke_limits, np.float64))]
        if any(lim != tuple(map(float, stroke_limits_mm)) for lim in own):
            raise ValueError(f"the geometry has its own stroke_limits {own[0]} mm, which the export uses; the "
                             f"stroke limits given ({tuple(stroke_limits_mm)} mm) contradict them: drop one")
    if mechanism.stroke_limits is None:
        if stroke_limits_mm is None:
            raise ValueError(
                "the geometry has no stroke_limits, and LinuxCNC's joint limits are lengths0 + the stroke "
                "limits: add \"stroke_limits\": [min, max] (mm of reading) to the geometry file, or give them "
                "(--stroke-limits-mm MIN,MAX)"
            )
        lo, hi = (float(x) for x in stroke_limits_mm)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < 0.0 < hi):
            raise ValueError(f"stroke limits must be finite with min < 0 < max (mm), got {stroke_limits_mm}")
        shortest = float(np.min(np.asarray(mechanism.lengths0)))
        if lo <= -shortest:
            raise ValueError(f"stroke limit min {lo} mm would shorten a strut of {shortest:.4g} mm (lengths0) to "
                             "zero or less: the limits contradict the geometry (µm typed for mm?)")
        mechanism = UPSMechanism(
            mechanism.base,
            mechanism.platform,
            mechanism.v0,
            mechanism.lengths0,
            stroke_limits=(lo, hi),
            joint_angle_limit=mechanism.joint_angle_limit,
            travel=mechanism.travel,
        )
    if not name or any(c in name for c in "/\\ \t\n[]"):
        raise ValueError(f"the configuration name must be a plain file stem, got {name!r}")
    base = np.asarray(mechanism.base, dtype=np.float64)
    platform = np.asarray(mechanism.platform, dtype=np.float64)
    v0 = np.asarray(mechanism.v0, dtype=np.float64)
    lengths0 = np.asarray(mechanism.lengths0, dtype=np.float64)
    home = np.concatenate([v0, np.zeros(3)])
    joint_home = np.linalg.norm(platform + v0 - base, axis=1)
    # the strut lengths LinuxCNC would command for the library's zero pose sent unshifted (X Y Z = 0)
    unshifted_change = float(np.max(np.abs(np.linalg.norm(platform - base, axis=1) - joint_home)))
    limits = np.asarray(mechanism.stroke_limits, dtype=np.float64)
    joint_limits = lengths0[:, None] + limits
    if np.any(joint_home <= joint_limits[:, 0]) or np.any(joint_home >= joint_limits[:, 1]):
        raise ValueError(
            "the pivot pose is outside the stroke limits (a strut's home length is not within lengths0 + "
            f"stroke_limits): home {joint_home.tolist()}, limits {joint_limits.tolist()}"
        )
    # NOTE: the search along each axis stops at 10 strokes' span (mm) and 0.5 rad; an extent that
    # reaches that cap is not a limit of the struts, and the INI says so.
    cap = np.array([10.0 * float(np.max(limits[:, 1] - limits[:, 0]))] * 3 + [_MAX_ANGLE_RAD] * 3)
    travel = max_travel(mechanism, max_extent_mm=float(cap[0]), max_extent_rad=_MAX_ANGLE_RAD)
    plus, minus = np.asarray(travel.plus), np.asarray(travel.minus)
    capped = (plus >= cap * (1 - 1e-9)) | (minus >= cap * (1 - 1e-9))
    axis_limits = np.stack([home - minus, home + plus], axis=1)
    axis_limits[3:] = np.degrees(np.stack([-minus[3:], plus[3:]], axis=1))
    return LinuxCNCConfig(
        ini=_ini(name, home, joint_home, joint_limits, axis_limits, capped, unshifted_change),
        hal=_hal(hal_setp, name),
        tool_table=f"; {name}: no tools (a tool length offset would move the rotation centre off the pivot)\n",
        user_hal=_user_hal(name),
        home=home,
        joint_home_mm=joint_home,
        joint_limits_mm=joint_limits,
        axis_limits=axis_limits,
    )


def _num(x: float) -> str:
    return repr(float(x))


def _ini(name, home, joint_home, joint_limits, axis_limits, capped, unshifted_change) -> str:
    """The INI file's text: the machine's sections (:func:`_ini_machine`), ``[TRAJ]``
    (:func:`_ini_traj`), the joints and the axes."""
    lines = _ini_machine(name, home, unshifted_change) + _ini_traj(home)
    lines += _ini_joints(joint_home, joint_limits) + _ini_axes(axis_limits, capped)
    return "\n".join(lines)


def _ini_machine(name: str, home, unshifted_change: float) -> list[str]:
    """The INI's lines up to ``[KINS]``: the header on the shifted coordinates (``home``, mm and
    degrees; ``unshifted_change``, the strut change of an unshifted command, mm), then
    ``[EMC]``, ``[DISPLAY]``, ``[RS274NGC]``, ``[EMCMOT]``, ``[TASK]``, ``[HAL]``, ``[EMCIO]``,
    ``[KINS]``."""
    return [
        "# LinuxCNC configuration of a 6-UPS strut hexapod for genhexkins, written by stewart_jax.",
        "# Units: mm and degrees. World coordinates are the controller's, shifted from the library's pose:",
        "#   X Y Z = d + v0 (the platform frame's origin in the base frame), A B C = phi theta psi in degrees.",
        "# Command X Y Z = v0 (the [TRAJ]HOME below) to put the platform at the library's zero pose.",
        f"# Commanding the library's d unshifted (X Y Z = 0 for the zero pose) moves the platform |v0| = "
        f"{np.linalg.norm(home[:3]):.4f} mm",
        f"# from it and changes a strut's length by up to {unshifted_change:.4f} mm (LinuxCNC refuses it: "
        "outside the joint limits).",
        "",
        "[EMC]",
        "VERSION = 1.1",
        f"MACHINE = {name} (genhexkins, stewart_jax)",
        "",
        "[DISPLAY]",
        "DISPLAY = axis",
        "POSITION_OFFSET = RELATIVE",
        "POSITION_FEEDBACK = ACTUAL",
        "",
        "[RS274NGC]",
        "# G21: programs in mm; G49: no tool length offset (it would move the pivot, see the HAL file)",
        "RS274NGC_STARTUP_CODE = G21 G49",
        f"PARAMETER_FILE = {name}.var",
        "",
        "[EMCMOT]",
        "EMCMOT = motmod",
        "COMM_TIMEOUT = 1.0",
        "SERVO_PERIOD = 1000000",
        "",
        "[TASK]",
        "TASK = milltask",
        "CYCLE_TIME = 0.010",
        "",
        "[HAL]",
        f"HALFILE = {name}.hal",
        "",
        "[EMCIO]",
        "# the I/O controller that takes the machine out of E-stop (without it LinuxCNC stays in E-stop)",
        "EMCIO = io",
        "CYCLE_TIME = 0.100",
        f"TOOL_TABLE = {name}.tbl",
        "",
        "[KINS]",
        "KINEMATICS = genhexkins",
        "JOINTS = 6",
        "",
    ]


def _ini_traj(home) -> list[str]:
    """The INI's ``[TRAJ]`` lines: the coordinates and units, ``HOME`` (``home``, mm and degrees)
    and the placeholder velocities."""
    return [
        "[TRAJ]",
        "COORDINATES = X Y Z A B C",
        "LINEAR_UNITS = mm",
        "ANGULAR_UNITS = degree",
        "# genhexkins starts its forward-kinematics iteration here: the pivot pose (v0, zero angles).",
        "HOME = " + " ".join(_num(x) for x in home),
        "NO_FORCE_HOMING = 1",
        "# velocities and accelerations are placeholders: set them from the actuators' ratings",
        f"DEFAULT_LINEAR_VELOCITY = {_JOINT_MAX_VELOCITY_MM_S / 2}",
        f"MAX_LINEAR_VELOCITY = {_JOINT_MAX_VELOCITY_MM_S}",
        f"DEFAULT_ANGULAR_VELOCITY = {_ANGULAR_MAX_VELOCITY_DEG_S / 2}",
        f"MAX_ANGULAR_VELOCITY = {_ANGULAR_MAX_VELOCITY_DEG_S}",
        "",
    ]


def _ini_joints(joint_home, joint_limits) -> list[str]:
    """The INI's ``[JOINT_0..5]`` lines: each strut's limits (``joint_limits``, ``(6, 2)``, mm) and
    home length (``joint_home``, ``(6,)``, mm)."""
    lines = []
    for n in range(6):
        lines += [
            f"[JOINT_{n}]",
            f"# strut {n + 1}: joint value = strut length (mm) = lengths0 + reading",
            "TYPE = LINEAR",
            f"MAX_VELOCITY = {_JOINT_MAX_VELOCITY_MM_S}",
            f"MAX_ACCELERATION = {_JOINT_MAX_ACCELERATION_MM_S2}",
            "# lengths0 + the stroke limits",
            f"MIN_LIMIT = {_num(joint_limits[n, 0])}",
            f"MAX_LIMIT = {_num(joint_limits[n, 1])}",
            "# the strut length at [TRAJ]HOME; HOME_OFFSET assumes the home switch is there",
            f"HOME = {_num(joint_home[n])}",
            f"HOME_OFFSET = {_num(joint_home[n])}",
            "HOME_SEQUENCE = 0",
            "",
        ]
    return lines


def _ini_axes(axis_limits, capped) -> list[str]:
    """The INI's ``[AXIS_X..C]`` lines: each axis's limits (``axis_limits``, ``(6, 2)``, mm and
    degrees), marked where ``capped`` (``(6,)`` bools) says the search's cap bounds them."""
    lines = []
    for k, axis in enumerate("XYZABC"):
        unit = "mm" if k < 3 else "degrees"
        lines += [
            f"[AXIS_{axis}]",
            f"# the workspace along {axis} from the pivot pose, the other five held there ({unit})"
            + ("; the search's cap, not a strut limit: the joint limits bound it" if capped[k] else ""),
            f"MIN_LIMIT = {_num(axis_limits[k, 0])}",
            f"MAX_LIMIT = {_num(axis_limits[k, 1])}",
            f"MAX_VELOCITY = {_JOINT_MAX_VELOCITY_MM_S if k < 3 else _ANGULAR_MAX_VELOCITY_DEG_S}",
            f"MAX_ACCELERATION = {_JOINT_MAX_ACCELERATION_MM_S2}",
            "",
        ]
    return lines


def _hal(setp: str, name: str) -> str:
    lines = [
        "# HAL file of a 6-UPS strut hexapod for genhexkins, written by stewart_jax (mm).",
        "loadrt [KINS]KINEMATICS",
        "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
        "addf motion-command-handler servo-thread",
        "addf motion-controller servo-thread",
        "",
        setp.rstrip("\n"),
        "",
        "# Held at 0. genhexkins adds tool-offset and spindle-offset to the z of every base and platform",
        "# joint, which moves the rotation centre off the calibrated pivot (a G43 offset of 100 mm gives",
        "# 0.1 mm of strut error at A = 0.1 degree); do not connect tool-offset to motion.tooloffset.z.",
        "# screw-lead corrects strut lengths for screw rotation, which the calibrated geometry does not model.",
        "setp genhexkins.tool-offset 0",
        "setp genhexkins.spindle-offset 0",
        "setp genhexkins.screw-lead 0",
        "",
        "# The machine's own wiring (drives, feedback, E-stop, tool changer) lives in the user's HAL",
        f"# file, which the export writes once and never replaces: edit {name}_user.hal, not this file.",
        f"source {name}_user.hal",
        "",
    ]
    return "\n".join(lines)


def _user_hal(name: str) -> str:
    lines = [
        f"# The user's HAL file of {name}, sourced by {name}.hal. stewart_jax writes it once, when it is",
        "# missing, and never replaces it: a re-export after a recalibration keeps these lines.",
        "# A simulated joint loop (commanded = measured strut length). Replace these six nets with the",
        "# machine's drives: each joint's feedback is lengths0 + that strut's reading, in mm.",
    ]
    for n in range(6):
        lines.append(f"net j{n}-pos joint.{n}.motor-pos-cmd => joint.{n}.motor-pos-fb")
    lines += [
        "",
        "# A machine with no tool changer: keep the tool-prepare handshake closed.",
        "net tool-prep-loop iocontrol.0.tool-prepare => iocontrol.0.tool-prepared",
        "net tool-change-loop iocontrol.0.tool-change => iocontrol.0.tool-changed",
        "net estop-loop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in",
        "",
    ]
    return "\n".join(lines)
