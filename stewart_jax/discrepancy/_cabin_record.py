"""A record of the FAST cabin's free vibration as a discrepancy model: is the paper's
quasi-static cable model (Yin, Jiang, Chen, Yao, "Dynamic modeling of a cable-driven parallel
robot with a Stewart platform for use in FAST") enough to explain how the cabin swings, and if
not, which physical effect is missing?

**Rows** are the samples of a record (``stewart-jax fast --free-decay`` writes one; FAST's
measuring system reports the cabin's pose continuously). **Observations** are the cabin's pose
relative to its static pose: C's origin in G (x, y, z; **mm**) and the rotation vector of its
small rotation in G (rx, ry, rz; **mrad** inside, degrees in the file). Residuals are reported
in µm and µrad. The **noise** is white, independent Gaussian, σ per position coordinate and per
rotation component (the tracker's).

The **base model** is the cabin's free vibration on its six quasi-static modes
(:mod:`stewart_jax.cable_robot`'s modal model, μ = 0): 19 base parameters, the initial
displacement ``q0`` (mm, mrad) and velocity ``v0`` (mm/s, mrad/s) at the record's first sample,
one damping ratio ``ζ`` for every mode, and a constant offset (mm, mrad) of the measured pose.

The effects (registered under ``"fast-cabin"``; θ = 0 is the base model):

- ``cable_inertia`` (μ, β, γ): the share μ of the cables' mass that moves with them — the
  lumped-mass cables (MoorDyn's discretisation) reduced exactly to the cabin and the cables'
  fixed-interface modes; μ = 1 is the lumped model, μ = 0 the paper's quasi-static cables —,
  the lag β of the cables' nodes at the record's start (0: in equilibrium with the displaced
  cabin; 1: at rest), and the continuum share γ of their discretisation (0: the model's N
  segments; 1: continuous cables, :mod:`~stewart_jax.cable_robot._cable_continuum`).
- ``cable_stiffness`` (κ, %): the cables' EA is ``(1 + κ)`` × the paper's, the statics solved
  again at the same position (the winches hold the cabin where it is).
- ``cabin_mass`` (κ_m, %): every mass and inertia of the cabin assembly (cabin, platforms,
  legs) is ``(1 + κ_m)`` ×; its weight changes the tensions, and the stiffness with them.
- ``damping`` (δζ, 3): the damping ratio of each mode group (swing, heave, rotation) differs from
  the common ζ by δζ_g.

NOTE (starting points): a cable inertia of μ = 1 halves the cabin's swing frequency; over a
record of tens of periods the phase of a model with a slightly wrong frequency is anywhere, so
a fit started at θ = 0 cannot find it, and a grid fine enough in phase grows with the record's
length. The model instead reads the record's own modes first (the multi-channel matrix pencil,
:mod:`stewart_jax.cable_robot._pencil`, on the record whitened by the tracker's noise; linear in
its length) and offers the workflow, per effect that changes frequencies, the few values at
which the model's modes that move the cabin match those frequencies best
(:meth:`CabinRecordModel.effect_grid`, :func:`~._cabin_starts.frequency_starts`): for
``cable_inertia`` the pairs (μ, γ) of the full reduced model with its string modes, for the
others the cabin's six modes. The physical fit then starts within a fraction of a phase step of
the record's frequencies, however long the record.

NOTE (record length): the model's time and memory are linear in the record's length (the modes
are summed in blocks, :data:`~stewart_jax.cable_robot._cabin_modal.TIME_CHUNK`); a record whose
fits would not fit in this machine's memory is refused before any fit, with the longest record
it can take (:func:`check_memory`).
"""

from __future__ import annotations

import math
import os
from typing import ClassVar, NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._memory import most_that_fit
from ..cable_robot._cabin_modal import (
    DAMPING_GROUPS,
    CabinModalModel,
    CabinVariation,
    cabin_modal_model,
    cabin_modal_modes,
    free_response,
)
from ..cable_robot._free_decay import RECORD_COLUMNS, CabinRecord, check_record
from ._cabin_starts import GRID_PARAMS, MASS_SHARE_RANGE, SECOND_STARTS, frequency_starts, record_frequencies
from ._registry import AbstractDiscrepancyModel, Effect, register_effect

MODEL_NAME = "fast-cabin"
BASE_NAMES = (tuple(f"q0_{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))
              + tuple(f"v0_{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))
              + ("damping_ratio",) + tuple(f"offset_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")))
"""The 19 base parameters: initial displacement (mm, mrad), velocity (mm/s, mrad/s), the common
damping ratio, the constant offset of the measured pose (mm, mrad)."""
DAMPING_START = 0.005
"""The damping ratio the base fit starts from (FAST's cabin: ≥ 0.004, Li, Sun, Li, Yao, Universe
10(12):450, 2024)."""
BYTES_PER_SAMPLE = 60_000
"""Memory the workflow's fits take per sample of a record (bytes). An upper estimate: the
whitened Jacobians of every unknown on the training and held-out rows, the whiteners and the
candidates' held-out residuals, a few kB per sample, taken ten times for the fits' temporaries
(the modal sums themselves are bounded by their block, not the record). Measured: a diagnosing
process's peak grew by about 32 kB per sample between records of 6 000 and 36 000 samples
(``benchmarks/fast_cabin_record_length.py --durations 600,1800,3600``)."""
MIN_PERIODS = 2.0
"""A record must last this many periods of the base model's lowest mode."""
MAX_JITTER = 0.05
"""Largest deviation of a sampling step from the median step, relative (uneven sampling beyond
it is refused)."""
AMPLITUDE_FLOOR = 0.5
"""A record's pose group (position, rotation) whose largest standard deviation is below this
share of the noise σ contradicts its own noise (every measured value carries it): the wrong unit
(metres, radians) or too large a σ."""
MAX_POSITION_STD_MM = 10_000.0
"""Largest standard deviation of a recorded position coordinate (mm) a cabin's free vibration can
have (its cables hold it within a few metres of its static pose): beyond it the unit is wrong."""
MAX_ROTATION_STD_DEG = 30.0
"""Largest standard deviation of a recorded rotation component (degrees) of a free vibration."""
DEFAULT_SEGMENTS = 20
"""Segments per cable of the lumped-mass cables behind ``cable_inertia`` (the ``--segments`` of
``stewart-jax diagnose --geometry fast``; the same as ``stewart-jax fast --free-decay``'s).

NOTE: the lumped model's frequencies move as O(1/N²) with the segments, and over a record of
tens of periods a shift of 0.1 % is a fifth of a radian of phase. The continuum share γ of
``cable_inertia`` carries the model at N to cables of other segments or to continuous ones
(:mod:`~stewart_jax.cable_robot._cable_continuum`); at N = 20 that resolves the cabin's modes and
the string modes below 0.9 Hz to within 200 ppm, but the cables' own modes near 1 Hz only to
about 10⁻³. Measured on 200 s records of 80-segment cables (near continuous): released from
rest, which rings those modes, missed at N = 20 and named at N = 40 (γ = 0.75); released from
equilibrium, missed at N = 20 (the fit that won the starts' profiles began at γ = 0 and stayed
there; a first version, with one Richardson step and no start at γ = 0, named it, γ = 0.94)
and named at N = 40 (γ = 0.80). 20 is what
``fast --free-decay`` writes, and its records are named at γ = 0.00; records of real cables need
``--segments 40``."""


class CabinRecordData(NamedTuple):
    """A cabin record as the model reads it.

    - ``time``: ``Float[Array, "m"]``, s since the record's first sample.
    - ``pose``: ``Float[Array, "m 6"]``, C's origin (mm) and rotation vector (mrad), G,
      relative to the static pose.
    """

    time: Float[Array, " m"]
    pose: Float[Array, "m 6"]

    time_unit = ("s", 1.0)
    """The open term search's ``time`` factor: seconds (a session's is hours).

    NOTE: a record offers the search no pose factors: its measured pose is the observation
    itself, noise and the missing effect included, and a term in it regresses the residual on
    itself (measured: a tracker drifting on z was found as "z², on z" in 2 of 20 runs at 3 mm of
    noise). The coordinates enter through the ``reading`` factor, the model's *predicted*
    coordinate."""

    directions = None
    temperature = None
    poses = None
    """A record carries no approach directions, temperatures or pose factors (the NOTE above)."""

    def take(self, index) -> CabinRecordData:
        index = np.asarray(index)
        return CabinRecordData(self.time[index], self.pose[index])


def record_data(time, position_mm, rotation_deg, source: str = "record") -> CabinRecordData:
    """:class:`CabinRecordData` from a record's columns (s; mm; degrees), checked
    (:func:`~stewart_jax.cable_robot._free_decay.check_record`): times relative to the first sample,
    rotations in mrad."""
    t = np.asarray(time, dtype=np.float64)
    pose = np.concatenate([np.asarray(position_mm, dtype=np.float64),
                           np.deg2rad(np.asarray(rotation_deg, dtype=np.float64)) * 1e3], axis=1)
    check_record(t, pose, source)
    return CabinRecordData(jnp.asarray(t - t[0]), jnp.asarray(pose))


def read_cabin_record(source: str | os.PathLike[str] | CabinRecord) -> CabinRecordData:
    """Read a cabin record: a CSV (columns ``time,x,y,z,rx,ry,rz``: s; mm; degrees; other
    columns ignored) or a :class:`~stewart_jax.cable_robot._free_decay.CabinRecord` in memory
    (``FreeDecay.sample``'s), with a clear error for a missing
    column, a cell that is not a number, a time that does not increase, an uneven sampling."""
    if isinstance(source, CabinRecord):
        return record_data(source.time, source.position_mm, source.rotation_deg)
    from ..calibration._csv import read_csv_columns

    cols = read_csv_columns(source)
    missing = [c for c in RECORD_COLUMNS if c not in cols]
    if missing:
        raise ValueError(f"{source}: a cabin record needs the columns {list(RECORD_COLUMNS)}; missing {missing}")
    pos = np.stack([cols[c] for c in ("x", "y", "z")], axis=1)
    rot = np.stack([cols[c] for c in ("rx", "ry", "rz")], axis=1)
    return record_data(cols["time"], pos, rot, source=os.fspath(source))


class CabinRecordState(NamedTuple):
    """What the cabin-record effects change: the base parameters (``base``, 19, see
    :data:`BASE_NAMES`), the :class:`~stewart_jax.cable_robot.CabinVariation` (μ, κ, κ_m,
    δζ), and an ``offset`` added to the predicted pose (mm, mrad; ``(m, 6)`` or a scalar 0: what
    the open term search's terms add)."""

    base: Float[Array, "19"]
    variation: CabinVariation
    offset: Float[Array, "..."]


class CabinRecordModel(AbstractDiscrepancyModel):
    """The cabin's free vibration on the paper's quasi-static cables (base) and the effects that
    change it (see the module docstring).

    **Fields:** ``modal`` (:class:`~stewart_jax.cable_robot._cabin_modal.CabinModalModel` at the record's
    position), ``sigma_mm`` and ``sigma_mrad`` (the tracker's noise per position coordinate and
    rotation component), ``grids`` (static: effect name → starting values of its parameter, library
    units), ``duration_s`` (static, the record's span the grids were made for) and ``notes``
    (static: what the record's checks accepted but say, e.g. sampling jitter).
    """

    modal: CabinModalModel
    sigma_mm: float | Array
    sigma_mrad: float | Array
    grids: tuple[tuple[str, tuple[float, ...]], ...] = eqx.field(static=True, default=())
    duration_s: float = eqx.field(static=True, default=0.0)
    notes: tuple[str, ...] = eqx.field(static=True, default=())

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = ("x", "y", "z", "rx", "ry", "rz")
    report_unit: ClassVar[str] = "µm, µrad"
    report_factor: ClassVar[float] = 1e3
    fit_steps: ClassVar[int | None] = 6
    # the open term search (``_discovery.py``): Fourier pairs in time, the outputs' own units
    open_search: ClassVar[bool] = True
    open_search_periodic: ClassVar[tuple[str, ...]] = ("time",)
    output_units: ClassVar[tuple[str, ...]] = ("mm",) * 3 + ("mrad",) * 3
    output_report_units: ClassVar[tuple[str, ...]] = ("µm",) * 3 + ("µrad",) * 3
    output_noun: ClassVar[str] = "coordinate"
    time_unit: ClassVar[str] = CabinRecordData.time_unit[0]
    # NOTE: the fits eigen-decompose the modes; batched over records those become batched
    # LAPACK calls (``syevd``) that deadlock XLA's CPU thread pool in jaxlib 0.10 (measured: two
    # records of the FAST cabin hung in the first batched fit).
    batched_fits: ClassVar[bool] = False

    @property
    def base_initial(self) -> Float[Array, "19"]:
        return jnp.zeros(19).at[12].set(DAMPING_START)

    @property
    def base_scale(self) -> Float[Array, "19"]:
        lin, rot = 10.0, 1.0
        return jnp.asarray([lin] * 3 + [rot] * 3 + [lin] * 3 + [rot] * 3 + [DAMPING_START] + [1.0] * 3 + [0.1] * 3)

    def observed(self, data: CabinRecordData) -> Float[Array, "m 6"]:
        return data.pose

    def initial_state(self, base, data: CabinRecordData, control: bool) -> CabinRecordState:
        z = jnp.zeros((), jnp.float64)
        return CabinRecordState(base, CabinVariation(z, z, z, jnp.zeros(len(DAMPING_GROUPS)), z, z), z)

    def finish(self, state: CabinRecordState, data: CabinRecordData) -> Float[Array, "m 6"]:
        b = state.base
        q = free_response(self.modal, state.variation, b[12], b[:6] * 1e-3, b[6:12] * 1e-3, data.time)
        return b[13:] + 1e3 * q + state.offset

    def whitener(self, base, data: CabinRecordData) -> Float[Array, "m 6 6"]:
        w = jnp.concatenate([jnp.full(3, 1.0 / self.sigma_mm), jnp.full(3, 1.0 / self.sigma_mrad)])
        return jnp.broadcast_to(jnp.diag(w), (data.time.shape[0], 6, 6))

    def columns(self, data: CabinRecordData) -> frozenset[str]:
        return frozenset({"time"})

    def n_rows(self, data: CabinRecordData) -> int:
        return int(data.time.shape[0])

    def take(self, data: CabinRecordData, index) -> CabinRecordData:
        return data.take(index)

    def factors(self, data: CabinRecordData) -> dict[str, np.ndarray]:
        """Time since the record's first sample."""
        m = self.n_rows(data)
        return {"time_s": np.broadcast_to(np.asarray(data.time)[:, None], (m, 6))}

    def effect_grid(self, effects) -> np.ndarray | None:
        grids = dict(self.grids)
        rows = [np.zeros(sum(e.n_params for e in effects))]
        off = 0
        for e in effects:
            which = GRID_PARAMS.get(e.name, (0,))
            for v in grids.get(e.name, ()):
                for second in SECOND_STARTS.get(e.name, (0.0,)):
                    row = np.zeros_like(rows[0])
                    for i, x in zip(which, np.atleast_1d(v), strict=True):
                        row[off + i] = x / e.scale[i]
                    if second:
                        row[off + 1] = second / e.scale[1]
                    rows.append(row)
            off += e.n_params
        return np.stack(rows)

    def variation(self, effects, thetas) -> CabinVariation:
        """The :class:`~stewart_jax.cable_robot.CabinVariation` of fitted effects."""
        state = self.initial_state(self.base_initial, None, False)
        for e, t in zip(effects, thetas, strict=True):
            if e.name != "discovered":  # the open search's terms add to the measured pose, not to the modes
                state = e(jnp.asarray(t), None, state)
        return state.variation


def check_memory(n_samples: int, rate_hz: float) -> None:
    """Refuse, before any fit, a record of ``n_samples`` whose fits would take more than
    :data:`~stewart_jax._memory.MEMORY_SHARE` of this machine's available memory, saying how long a record (samples,
    and minutes at ``rate_hz``) it can take."""
    fit = most_that_fit(BYTES_PER_SAMPLE)
    if fit is None:
        return
    most, available = fit
    if n_samples > most:
        raise ValueError(
            f"the record has {n_samples} samples; diagnosing it needs about "
            f"{n_samples * BYTES_PER_SAMPLE / 1e9:.1f} GB "
            f"and this machine has {available / 1e9:.1f} GB available: it can take records of up to {most} samples "
            f"({most / rate_hz / 60.0:.0f} min at the record's {rate_hz:.4g} Hz); resample the record to a lower rate "
            "(its modes lie below 1.5 Hz) or diagnose it on a machine with more memory")


def cabin_record_model(
    data: CabinRecordData,
    position=(0.0, 0.0, 140.0),
    *,
    segments: int = DEFAULT_SEGMENTS,
    sigma_um: float = 1000.0,
    sigma_arcsec: float = 36.0,
    params=None,
    modal: CabinModalModel | None = None,
) -> CabinRecordModel:
    """The :class:`CabinRecordModel` of a record ``data`` taken with the cabin at ``position``
    (m; level attitude), the lumped cables of ``cable_inertia`` with ``segments`` segments, and
    the tracker's noise σ (``sigma_um`` per position coordinate, µm; ``sigma_arcsec`` per
    rotation component, ″). ``modal`` reuses a :func:`~stewart_jax.cable_robot.cabin_modal_model`
    built for the same position (it is the expensive part: the lumped statics and modes).

    Raises ``ValueError`` (before any fit) for a record whose size contradicts its units or noise
    (:func:`check_amplitude`), sampled unevenly (steps deviating from
    the median by more than :data:`MAX_JITTER`), too slowly to resolve the base model's highest
    mode (Nyquist), or too short to resolve its lowest (fewer than :data:`MIN_PERIODS` periods).
    """
    from ..cable_robot import paper_fast_params

    for name, s in (("sigma_um", sigma_um), ("sigma_arcsec", sigma_arcsec)):
        if not (np.isfinite(s) and s > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {s}")
    sigma_mm, sigma_mrad = sigma_um * 1e-3, sigma_arcsec * math.pi / 648.0
    check_amplitude(data, sigma_mm, sigma_mrad)
    params = paper_fast_params() if params is None else params
    if modal is None:
        modal = cabin_modal_model(params, position, segments)
    elif not np.allclose(np.asarray(modal.position), np.asarray(position, dtype=np.float64)):
        raise ValueError(f"the modal model is for {np.asarray(modal.position).tolist()} m, not {list(position)} m")
    notes = check_sampling(data, modal)
    t = np.asarray(data.time)
    check_memory(len(t), 1.0 / float(np.median(np.diff(t))))
    duration = float(t[-1] - t[0])
    f_rec, weight, cutoff = record_frequencies(data, modal, sigma_mm, sigma_mrad)
    ranges = {"cable_inertia": MASS_SHARE_RANGE, "cable_stiffness": modal.ea_range, "cabin_mass": modal.mass_range}
    grids = tuple((name, frequency_starts(modal, name, lo, hi, f_rec, weight, cutoff))
                  for name, (lo, hi) in ranges.items())
    return CabinRecordModel(modal, jnp.asarray(sigma_mm), jnp.asarray(sigma_mrad), grids, duration, tuple(notes))


def check_amplitude(data: CabinRecordData, sigma_mm: float, sigma_mrad: float) -> None:
    """Clear errors for a record whose size contradicts its units: a pose group (x, y, z in mm;
    rx, ry, rz in degrees) that varies less than :data:`AMPLITUDE_FLOOR` × its noise σ (a
    record in metres or radians, or σ stated too large), or more than a free vibration can
    (:data:`MAX_POSITION_STD_MM`, :data:`MAX_ROTATION_STD_DEG`: a record in µm or arcseconds)."""
    std = np.std(np.asarray(data.pose), axis=0)
    pos_mm, rot_deg = float(np.max(std[:3])), float(np.rad2deg(np.max(std[3:]) * 1e-3))
    sigma_deg = float(np.rad2deg(sigma_mrad * 1e-3))
    if pos_mm < AMPLITUDE_FLOOR * sigma_mm:
        raise ValueError(
            f"the record's positions x, y, z vary by at most {pos_mm:.3g} mm (standard deviation), less than "
            f"{AMPLITUDE_FLOOR:g} × the tracker's noise σ = {sigma_mm:.4g} mm that every measured value carries: "
            "the columns are mm (a record in metres reads 1000× too small), or give the tracker's σ with --sigma-um")
    if rot_deg < AMPLITUDE_FLOOR * sigma_deg:
        raise ValueError(
            f"the record's rotations rx, ry, rz vary by at most {rot_deg:.3g}° (standard deviation), less than "
            f"{AMPLITUDE_FLOOR:g} × the tracker's noise σ = {sigma_deg:.4g}° that every measured value carries: "
            "the columns are degrees (a record in radians reads 57× too small), or give the tracker's σ with "
            "--sigma-arcsec")
    if pos_mm > MAX_POSITION_STD_MM:
        raise ValueError(f"the record's positions vary by {pos_mm:.4g} mm (standard deviation): more than "
                         f"{MAX_POSITION_STD_MM / 1e3:g} m, which no free vibration of the cabin reaches; the "
                         "columns are mm (a record in µm reads 1000× too large)")
    if rot_deg > MAX_ROTATION_STD_DEG:
        raise ValueError(f"the record's rotations vary by {rot_deg:.4g}° (standard deviation): more than "
                         f"{MAX_ROTATION_STD_DEG:g}°, which no free vibration of the cabin reaches; the columns are "
                         "degrees (a record in arcseconds or mrad reads too large)")


def check_sampling(data: CabinRecordData, modal: CabinModalModel) -> list[str]:
    """Clear errors for a record the base model cannot resolve (see :func:`cabin_record_model`);
    returns notes for what is accepted but worth saying (sampling jitter)."""
    t = np.asarray(data.time)
    f = np.asarray(cabin_modal_modes(modal, CabinVariation()).frequencies_hz)[:6]
    step = np.diff(t)
    h = float(np.median(step))
    jitter = float(np.max(np.abs(step - h)) / h)
    if jitter > MAX_JITTER:
        i = int(np.argmax(np.abs(step - h)))
        raise ValueError(
            f"uneven sampling: the step after t = {t[i]:.6g} s is {step[i]:.6g} s, the median step {h:.6g} s "
            f"(steps may deviate by {100 * MAX_JITTER:.0f} % at most); resample the record to a uniform rate or "
            "split it at the gap")
    rate = 1.0 / h
    if rate <= 2.0 * f[-1]:
        raise ValueError(f"the record is sampled at {rate:.4g} Hz, at or below twice the highest mode of the "
                         f"quasi-static model ({f[-1]:.4g} Hz): it cannot resolve that mode (Nyquist)")
    span = float(t[-1] - t[0])
    if span < MIN_PERIODS / f[0]:
        raise ValueError(f"the record lasts {span:.4g} s: too short to resolve the lowest mode of the quasi-static "
                         f"model ({f[0]:.4g} Hz) — at least {MIN_PERIODS:g} periods, {MIN_PERIODS / f[0]:.3g} s, "
                         "are needed")
    notes = []
    if jitter > 1e-6:
        notes.append(f"sampling steps deviate from the median {h:.6g} s by up to {100 * jitter:.2g} %; the model "
                     "is evaluated at the recorded times (nothing resampled)")
    return notes


# ---------------------------------------------------------------------------- effects


@register_effect(MODEL_NAME, "cable_inertia", n_params=3, scale=(0.3, 0.3, 0.3),
                 unit="share of the cables' mass; lag of the cables' nodes; continuum share")
def cable_inertia(theta: Float[Array, "3"], data, state: CabinRecordState) -> CabinRecordState:
    """The cables have mass that moves: lumped-mass cables (MoorDyn's discretisation, reduced
    exactly to the cabin and the cables' fixed-interface string modes), θ₀ the share μ of the
    cables' mass that moves (0: the paper's quasi-static cables; 1: the lumped-mass model), θ₁ the
    lag β of the cables' nodes at the record's start (0: in the quasi-static shape of the cabin's
    initial offset, released from a static offset under a load; 1: at rest in the static pose,
    the cabin struck or displaced faster than the string modes follow), θ₂ the continuum share γ
    of the cables' discretisation (0: the model's N segments; 1: continuous cables; γ stands for
    ``N/√(1 − γ)`` segments)."""
    v = state.variation
    return state._replace(variation=v._replace(cable_mass_share=v.cable_mass_share + theta[0],
                                               node_lag=v.node_lag + theta[1],
                                               continuum=v.continuum + theta[2]))


@register_effect(MODEL_NAME, "cable_stiffness", n_params=1, scale=0.1, unit="% of EA", report_factor=100.0)
def cable_stiffness(theta: Float[Array, "1"], data, state: CabinRecordState) -> CabinRecordState:
    """The cables' axial stiffness is EA (1 + κ): the statics solved again at the same position
    (the winches keep the cabin there), the catenaries' stiffness with them."""
    v = state.variation
    return state._replace(variation=v._replace(ea_change=v.ea_change + theta[0]))


@register_effect(MODEL_NAME, "cabin_mass", n_params=1, scale=0.05, unit="% of the assembly's mass",
                 report_factor=100.0)
def cabin_mass(theta: Float[Array, "1"], data, state: CabinRecordState) -> CabinRecordState:
    """Every mass and inertia of the cabin assembly (cabin + upper platform, legs, lower
    platform) is (1 + κ_m) × the paper's: more inertia, and more weight, which raises the
    tensions (statics solved again at the same position) and the pendulum stiffness with them."""
    v = state.variation
    return state._replace(variation=v._replace(mass_change=v.mass_change + theta[0]))


@register_effect(MODEL_NAME, "damping", n_params=3, scale=2e-3, unit="damping ratio (swing, heave, rotation)")
def damping(theta: Float[Array, "3"], data, state: CabinRecordState) -> CabinRecordState:
    """The modes are damped differently by group: each mode's damping ratio is ζ + Σ_g δζ_g s_g,
    s_g its share of cabin kinetic energy in the swing (x, y), heave (z) and rotation groups."""
    v = state.variation
    return state._replace(variation=v._replace(damping_change=v.damping_change + theta))


def fitted_modes(model: CabinRecordModel, effects: tuple[Effect, ...] = (), thetas=(), cutoff_hz: float = 1.5,
                 min_share: float = 0.01) -> dict:
    """The modes of the (augmented) model below ``cutoff_hz`` that move the cabin (its kinetic
    energy share ≥ ``min_share``): ``frequencies_hz``, ``cabin_energy_share``, and per mode the
    group of :data:`~stewart_jax.cable_robot._cabin_modal.DAMPING_GROUPS` holding most of its cabin energy."""
    var = model.variation(effects, thetas)
    m = cabin_modal_modes(model.modal, var)
    f = np.asarray(m.frequencies_hz)
    e = np.asarray(m.cabin_energy_share)
    g = np.asarray(m.group_share)
    keep = (f < cutoff_hz) & (e >= min_share)
    return {"frequencies_hz": f[keep].tolist(), "cabin_energy_share": e[keep].tolist(),
            "group": [DAMPING_GROUPS[int(i)] for i in np.argmax(g[keep], axis=1)],
            "cutoff_hz": cutoff_hz, "min_cabin_energy_share": min_share}
