"""Open search for the missing effect: sparse regression over a library of terms in the
session's factors, in the manner of SINDy (Brunton, Proctor, Kutz 2016, "Discovering governing
equations from data by sparse identification of nonlinear dynamical systems", PNAS 113(15);
de Silva et al. 2020, "PySINDy: a Python package for the sparse identification of nonlinear
dynamical systems from data", JOSS 5(49)).

When no registered candidate closes the held-out gap, the residual of each actuator is
regressed on terms of the factors the data carry:

- the actuator's own reading ``q`` (mm for a strut or slider, degrees for a crank angle:
  :func:`reading_factor`): polynomials ``q^d`` (``d`` = 1, 2, 3) and Fourier pairs
  ``sin(2π q / P), cos(2π q / P)`` over a geometric grid of periods ``P`` (cyclic screw,
  gear-tooth and encoder errors), refined around the best one;
- the approach direction: a step ``dir / 2`` (lost motion);
- temperature ``T − 20 °C`` and its product with the reading (a temperature-dependent scale);
- time (hours, degree 1 and 2) and the pose components (degree 2).

A model declares the factors its data carry: a record of the FAST cabin's free vibration
(:class:`~stewart_jax.discrepancy.CabinRecordModel`) has no readings, directions or
temperatures; its outputs are the cabin's coordinates, and the search runs over Fourier pairs in
time (a vibration the model lacks: a mode, a forcing), polynomials in time (seconds: a drifting
instrument) and polynomials of each coordinate's own predicted value (``reading``: a scale error
or a nonlinearity of the measurement) — not over the measured pose, which is the observation
itself.

A *group* is one term on one actuator (``leg`` 1–6) or the same term on every actuator with
one coefficient each (``leg`` null). Groups are fitted jointly with the base parameters (the
whitened base Jacobian at the base fit is in every regression, so what the geometry can absorb
is not counted) and chosen by forward selection: at each step the group with the largest drop
of the Bayesian information criterion (Schwarz 1978) whose drop of the training χ² is
significant at ``alpha`` divided by the number of groups tried (Bonferroni over the library,
which guards the period search against chance); the search stops as soon as the augmented model
passes the held-out test that detected the discrepancy, at the same ``alpha``, or when no group
qualifies.

NOTE: the regression is the linearisation of the fit at the base optimum (the same one whose
prediction covariance the held-out test uses); the terms are linear in their coefficients and
the base parameters move by µm, so it is exact to ~1e-4 relative. The augmented model
(:class:`DiscoveredTerms` as an :class:`~stewart_jax.discrepancy.Effect`) evaluates a reading's
terms at the model's predicted reading, so it can be used to command moves.

Limits: a term the library cannot express (a period outside the grid, an interaction of two
pose components, a hysteresis loop wider than a step, a change at one instant) is not found;
the held-out gap then stays open and the report says so. A period is resolved when the readings
of the training poses span at least about two periods and their median spacing is below half a
period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple, Protocol

import jax.numpy as jnp
import numpy as np

from ._registry import AbstractDiscrepancyModel, Effect
from ._statistics import bic, heldout_chi2, heldout_p, nested_p
from ._subspace import SINE_TOL, basis

T_REF_C = 20.0
READING_FACTOR_UNITS = {"mm": (1.0, "mm"), "rad": (180 / math.pi, "deg")}
"""Per mechanism ``reading_unit``: the scale from the library's reading to the ``reading``
factor's unit, and that unit (a crank angle in degrees, as the measurement CSV and the pose
angles give it)."""
MAX_TERMS = 4
"""Most groups the forward selection adds."""
PERIOD_RATIO = 1.005
"""Ratio of neighbouring periods of the grid (a 0.25 % largest mismatch before refinement)."""
MIN_PERIODS_IN_RANGE = 1.5
"""The longest period tried: the readings' range / this."""
NYQUIST_SAMPLES = 2.0
"""The shortest period tried: this many times the readings' median spacing (Nyquist)."""


class SearchData(Protocol):
    """The data contract of a model that declares ``open_search``: the factors its rows offer the
    search, each ``None`` where the data do not carry it (a class attribute ``None`` where the
    data type never does, e.g. a cabin record's directions).

    - ``time``: ``Float[Array, "m"] | None``, s since the start;
    - ``time_unit``: ``(unit, seconds per unit)`` of the ``time`` factor (``("h", 3600.0)`` for
      a measurement session, ``("s", 1.0)`` for a record);
    - ``directions``: ``Float[Array, "m k"] | None``, the approach direction (±1) per actuator;
    - ``temperature``: ``Float[Array, "m"] | None``, °C;
    - ``poses``: ``Float[Array, "m 6"] | None``, the measured poses (mm, rad).
    """

    time_unit: tuple[str, float]

    @property
    def time(self) -> Any: ...

    @property
    def directions(self) -> Any: ...

    @property
    def temperature(self) -> Any: ...

    @property
    def poses(self) -> Any: ...


_POSE = (("x", 0, 1.0, "mm"), ("y", 1, 1.0, "mm"), ("z", 2, 1.0, "mm"),
         ("rx", 3, 180 / math.pi, "deg"), ("ry", 4, 180 / math.pi, "deg"), ("rz", 5, 180 / math.pi, "deg"))


class TermSpec(NamedTuple):
    """One term group: ``factor`` (``reading``, ``dir``, ``temperature``, ``time``, ``x`` … ``rz``),
    ``form`` (``periodic``, ``polynomial``, ``step``), ``period`` (factor unit; periodic),
    ``degree`` (polynomial), ``times`` (``"temperature"`` for a product with temperature, else
    ``""``), ``leg`` (0-based actuator, or ``None`` for every actuator)."""

    factor: str
    form: str
    period: float | None
    degree: int | None
    times: str
    leg: int | None


def reading_factor(model: AbstractDiscrepancyModel) -> tuple[float, str]:
    """``(scale, unit)``: the ``reading`` factor is ``scale`` × the model's reading (library
    unit, the mechanism's ``reading_unit``), in ``unit`` (mm; degrees for a crank angle)."""
    unit = model.reading_unit
    if unit not in READING_FACTOR_UNITS:
        raise ValueError(f"the open term search has no factor unit for readings in {unit!r}")
    return READING_FACTOR_UNITS[unit]


def _factor_x(spec: TermSpec, reading, data, xp=np):
    """``(m, k)`` values of the term's factor: ``reading`` in the factor's unit (the caller
    scales it: :func:`reading_factor`), poses in mm and degrees, temperature minus 20 °C, time
    in the data's ``time_unit``."""
    m, k = reading.shape
    if spec.factor == "reading":
        return reading
    if spec.factor == "dir":
        return xp.asarray(data.directions)
    if spec.factor == "temperature":
        return xp.broadcast_to(xp.asarray(data.temperature)[:, None] - T_REF_C, (m, k))
    if spec.factor == "time":
        return xp.broadcast_to(xp.asarray(data.time)[:, None] / data.time_unit[1], (m, k))
    _, i, f, _ = next(p for p in _POSE if p[0] == spec.factor)
    return xp.broadcast_to(xp.asarray(data.poses)[:, i : i + 1] * f, (m, k))


def _factor_values(spec: TermSpec, reading, data) -> np.ndarray | jnp.ndarray:
    """``(m, k)`` values of the term's basis functions stacked on a last axis ``(m, k, c)``
    (the factor's units as in :func:`_factor_x`)."""
    xp = jnp if isinstance(reading, jnp.ndarray) and not isinstance(reading, np.ndarray) else np
    x = _factor_x(spec, reading, data, xp)
    if spec.form == "periodic":
        a = 2 * math.pi * x / spec.period
        cols = xp.stack([xp.sin(a), xp.cos(a)], axis=-1)
    elif spec.form == "step":
        cols = (0.5 * x)[..., None]
    else:
        cols = (x**spec.degree)[..., None]
    if spec.times == "temperature":
        cols = cols * (xp.asarray(data.temperature)[:, None, None] - T_REF_C)
    return cols


def _n_coef(spec: TermSpec) -> int:
    return 2 if spec.form == "periodic" else 1


def _legs(spec: TermSpec, k: int) -> list[int]:
    return list(range(k)) if spec.leg is None else [spec.leg]


class TermUnits(NamedTuple):
    """How a model's terms are named: per output, the ``reading`` factor's unit and the
    residual's report unit; the ``time`` factor's unit; the noun of an output (``actuator``,
    ``coordinate``) and its ``names`` (``None``: numbered from 1)."""

    reading: tuple[str, ...]
    report: tuple[str, ...]
    time: str
    noun: str
    names: tuple[str, ...] | None


def term_units(model: AbstractDiscrepancyModel) -> TermUnits:
    """The :class:`TermUnits` of ``model`` from its declarations (``output_units``,
    ``output_report_units``, ``time_unit``, ``output_noun``; by default a hexapod's readings in
    :func:`reading_factor`'s unit, its residuals in its report unit, time in hours)."""
    k = len(model.output_names)
    noun = model.output_noun
    return TermUnits(
        tuple(model.output_units or (reading_factor(model)[1],) * k),
        tuple(model.output_report_units or (model.report_unit,) * k),
        model.time_unit,
        noun,
        None if noun == "actuator" else tuple(model.output_names),
    )


def _unit(spec: TermSpec, units: TermUnits, leg: int) -> str:
    """Unit of a term's coefficient on output ``leg`` (0-based): the residual's report unit per
    unit of the basis."""
    if spec.form == "periodic" or spec.form == "step":
        per = ""
    else:
        u = {"reading": units.reading[leg], "temperature": "K", "time": units.time, "dir": ""}.get(spec.factor)
        u = u if u is not None else next(p[3] for p in _POSE if p[0] == spec.factor)
        per = u if spec.degree == 1 else f"{u}^{spec.degree}"
    if spec.times == "temperature":
        per = f"{per}·K" if per else "K"
    return f"{units.report[leg]}/{per}" if per else units.report[leg]


def period_unit(spec: TermSpec, units: TermUnits) -> str | None:
    """The unit of a periodic term's period (its factor's), else ``None``."""
    if spec.form != "periodic":
        return None
    return {"reading": units.reading[spec.leg or 0], "time": units.time}.get(spec.factor)


def describe(spec: TermSpec, units: TermUnits) -> str:
    """The term in words."""
    if spec.leg is None:
        who = f"every {units.noun}"
    else:
        who = f"{units.noun} {spec.leg + 1 if units.names is None else units.names[spec.leg]}"
    what = {"reading": "its reading" if units.noun == "actuator" else "its own value",
            "dir": "its approach direction"}.get(spec.factor, spec.factor)
    if spec.form == "periodic":
        unit = period_unit(spec, units) or ""
        unit = "°" if unit == "deg" else f" {unit}"
        kind = "error" if spec.factor == "reading" else "signal"
        s = f"a periodic {kind} in {what} with period {spec.period:.4g}{unit}".rstrip()
    elif spec.form == "step":
        s = f"a step with {what} (lost motion)"
    else:
        s = f"a degree-{spec.degree} polynomial in {what}"
    if spec.times == "temperature":
        s += " times the temperature"
    return f"{s}, on {who}"


class DiscoveredTerms(NamedTuple):
    """The discovered terms as one effect's definition: ``specs`` (the groups), ``k`` (outputs
    per row). Parameters: the coefficients of each group, leg by leg, basis function by basis
    function (library units: the reading's unit per unit of the basis)."""

    specs: tuple[TermSpec, ...]
    k: int

    @property
    def n_params(self) -> int:
        return sum(_n_coef(s) * len(_legs(s, self.k)) for s in self.specs)

    def offsets(self, theta, reading, data, scale: float = 1.0):
        """``(m, k)`` reading offsets of the terms at the readings ``reading`` (library unit;
        ``scale`` × ``reading`` is the factor's unit, :func:`reading_factor`)."""
        out = jnp.zeros(reading.shape)
        off = 0
        for s in self.specs:
            cols = _factor_values(s, reading * scale, data)
            for j in _legs(s, self.k):
                c = _n_coef(s)
                out = out.at[:, j].add(cols[:, j, :] @ theta[off : off + c])
                off += c
        return out

    def effect(self, model: Any) -> Effect:
        """An unregistered :class:`Effect` adding the terms to ``model``'s readings (the reading
        factor is the model's prediction before the terms)."""
        requires = {"dir": ("directions",), "temperature": ("temperature",), "time": ("time",)}
        req = sorted({c for s in self.specs for c in requires.get(s.factor, ()) + requires.get(s.times, ())})
        scale = reading_factor(model)[0]
        units = term_units(model)

        def apply(theta, data, state):
            reading = model.finish(state, data)
            return state._replace(offset=state.offset + self.offsets(theta, reading, data, scale))

        n = self.n_params
        return Effect(
            name="discovered", model=model.name, n_params=n, apply=apply, scale=(model.report_factor**-1,) * n,
            unit=model.report_unit, report_factor=(model.report_factor,) * n, requires=tuple(req),
            acts_on="mechanism", doc="; ".join(describe(s, units) for s in self.specs), terms=self,
        )

    def to_dict(self) -> dict[str, Any]:
        return {"k": self.k, "specs": [s._asdict() for s in self.specs]}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> DiscoveredTerms:
        return DiscoveredTerms(tuple(TermSpec(**s) for s in d["specs"]), int(d["k"]))


def supports_discovery(model: Any, data: Any) -> bool:
    """The open search applies to models that declare ``open_search`` (every mechanism's model:
    6-PSS, 6-UPS, 6-RUS; the FAST cabin record) and have an additive offset of their outputs in
    their state."""
    if not model.open_search:
        return False
    state = model.initial_state(model.base_initial, data, False)
    return isinstance(state, tuple) and "offset" in type(state)._fields


def _periods(x: np.ndarray) -> np.ndarray:
    """The geometric grid of periods for a factor whose training values (per output) are ``x``
    ``(m, k)``: from the shortest period the readings resolve to the range over
    :data:`MIN_PERIODS_IN_RANGE`; empty for a constant factor.

    NOTE: the shortest period is the Nyquist period of the readings' typical spacing, twice the
    median gap between neighbouring distinct values (per output, the median over outputs): a
    session's readings are scattered, so periods shorter than the mean spacing are resolved
    where the gaps are small, and a uniformly sampled record gets its own Nyquist period."""
    span = float(np.median(np.ptp(x, axis=0)))
    if not span > 0:
        return np.zeros(0)
    gaps = [np.diff(np.unique(col)) for col in np.asarray(x).T]
    gap = float(np.median([np.median(g) for g in gaps if g.size]))
    p_max = span / MIN_PERIODS_IN_RANGE
    p_min = min(NYQUIST_SAMPLES * gap, p_max)
    return p_min * PERIOD_RATIO ** np.arange(int(math.log(p_max / p_min) / math.log(PERIOD_RATIO)) + 1)


def _library(reading_tr: np.ndarray, data: SearchData, k: int,
             periodic: Sequence[str] = ("reading",)) -> list[list[TermSpec]]:
    """The candidate groups, as families (a family of periodic groups shares one period grid);
    Fourier pairs in the factors ``periodic`` (the model's ``open_search_periodic``)."""
    fams: list[list[TermSpec]] = []
    legs: list[int | None] = [None, *range(k)]
    time = data.time
    for factor in periodic:
        if factor == "time" and time is None:
            continue
        periods = _periods(_factor_x(TermSpec(factor, "periodic", 1.0, None, "", None), reading_tr, data))
        if periods.size:
            fams += [[TermSpec(factor, "periodic", float(p), None, "", leg) for p in periods] for leg in legs]
    if float(np.median(np.ptp(reading_tr, axis=0))) > 0:
        for d in (1, 2, 3):
            fams.append([TermSpec("reading", "polynomial", None, d, "", leg) for leg in legs])
    if data.directions is not None:
        fams.append([TermSpec("dir", "step", None, None, "", leg) for leg in legs])
    if data.temperature is not None:
        fams.append([TermSpec("temperature", "polynomial", None, 1, "", leg) for leg in legs])
        fams.append([TermSpec("reading", "polynomial", None, 1, "temperature", leg) for leg in legs])
    if time is not None:
        for d in (1, 2):
            fams.append([TermSpec("time", "polynomial", None, d, "", leg) for leg in legs])
    if data.poses is not None:
        for name, *_ in _POSE:
            fams.append([TermSpec(name, "polynomial", None, 2, "", leg) for leg in legs])
    return fams


def _columns(spec: TermSpec, reading, data, w) -> np.ndarray:
    """Whitened columns ``(n, c·legs)`` of one group: the residual changes by ``−W e_j t``
    per unit coefficient; the sign is folded into the coefficient (``r ≈ J δ + C c``). Column
    ``l·c + b`` of row ``i·k + o`` is ``w[i, o, leg_l] · basis_b(x[i, leg_l])``."""
    return _whiten(w, _factor_values(spec, reading, data)[None], _legs(spec, reading.shape[1]))[0]


def _whiten(w: np.ndarray, vals: np.ndarray, legs: list[int]) -> np.ndarray:
    """``(g, n, c·legs)`` columns of basis values ``vals`` ``(g, m, k, c)`` (see :func:`_columns`)."""
    g, m, k, c = vals.shape
    return (w[None, :, :, legs, None] * vals[:, :, None, legs, :]).reshape(g, m * k, len(legs) * c)


def _stack_columns(specs: Sequence[TermSpec], reading, data, w) -> np.ndarray:
    """:func:`_columns` of groups of equal width stacked, ``(g, n, p)``; the periods of a
    periodic family (one leg, one factor) in one vectorised evaluation."""
    s0 = specs[0]
    if s0.form == "periodic" and all(s._replace(period=s0.period) == s0 for s in specs):
        x = _factor_x(s0, reading, data)
        a = (2 * math.pi / np.array([s.period for s in specs]))[:, None, None] * x  # (g, m, k)
        vals = np.stack([np.sin(a), np.cos(a)], axis=-1)
        if s0.times == "temperature":
            vals = vals * (np.asarray(data.temperature)[None, :, None, None] - T_REF_C)
        return _whiten(w, vals, _legs(s0, reading.shape[1]))
    return np.stack([_columns(s, reading, data, w) for s in specs])


GRAM_SINE = 1e-4
"""Below this principal-angle sine of a column to the base span, :func:`_drops` projects the
column explicitly instead of through Gram matrices (whose subtraction loses ~1e-16 / sine²)."""


def _drops(q: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    """:func:`_drop` for a stack of column sets ``c`` ``(g, n, p)`` of equal width (a
    pseudo-inverse of each ``p × p`` Gram matrix of the unit-normalised projected columns, cut
    at the rank tolerance).

    NOTE: most of the open search's time is here, so the projected Gram matrix is formed as
    ``cᵀc − (Qᵀc)ᵀ(Qᵀc)`` and ``cpᵀr = cᵀr`` (``r`` is orthogonal to ``Q``) — products of
    ``p`` columns, no ``(g, n, p)`` temporaries. That subtraction is accurate to ~1e-16/sine²
    relative, so groups with a column closer to the base span than :data:`GRAM_SINE` are
    projected explicitly (``c − Q Qᵀ c``), which keeps the absorbed-column test at
    :data:`~stewart_jax.discrepancy._subspace.SINE_TOL` exact."""
    ct = np.swapaxes(c, 1, 2)
    qc = q.T @ c
    cc = ct @ c
    gram = cc - np.swapaxes(qc, 1, 2) @ qc
    nc, ng = np.diagonal(cc, axis1=1, axis2=2), np.diagonal(gram, axis1=1, axis2=2)
    close = np.any(ng <= GRAM_SINE**2 * nc, axis=-1)
    b = ct @ r
    if np.any(close):  # the columns of these groups projected explicitly
        cp = c[close] - q @ qc[close]
        norms2 = np.sum(cp * cp, axis=1)
        gram[close] = np.swapaxes(cp, 1, 2) @ cp
        ng = ng.copy()
        ng[close] = norms2
        b[close] = np.swapaxes(cp, 1, 2) @ r
    seen = ng > SINE_TOL**2 * nc  # directions the base does not absorb
    dinv = np.where(seen, 1.0 / np.sqrt(np.where(seen, ng, 1.0)), 0.0)
    b = b * dinv
    gram = gram * dinv[:, :, None] * dinv[:, None, :]
    return np.sum(b * (np.linalg.pinv(gram, rcond=1e-9, hermitian=True) @ b[..., None])[..., 0], axis=-1)


def _drop(q: np.ndarray, r: np.ndarray, c: np.ndarray) -> float:
    """Drop of ``|r|²`` when ``r`` (orthogonal to ``q``) is fitted by ``c`` as well as ``q``."""
    return float(_drops(q, r, c[None])[0])


CHUNK_BYTES = 64_000_000
"""Most memory one stack of a family's columns may take (bytes): the family is scored in chunks
of groups, so the search's memory is linear in the rows, whatever the number of periods."""


def _family_drops(fam, q, r, reading_tr, train, w_tr) -> np.ndarray:
    """:func:`_drops` of a family of groups of equal width ``(len(fam),)``, in chunks of at most
    :data:`CHUNK_BYTES`.

    NOTE: a 200 s record at 10 Hz has ~1300 periods in its grid: stacked at once, its 8400
    whitened rows × 14 columns per group took 1.2 GB, and an hour's record would take 30 GB."""
    width = _n_coef(fam[0]) * len(_legs(fam[0], reading_tr.shape[1]))
    chunk = max(1, int(CHUNK_BYTES // (8 * r.size * width)))
    return np.concatenate([_drops(q, r, _stack_columns(fam[i:i + chunk], reading_tr, train, w_tr))
                           for i in range(0, len(fam), chunk)])


def best_group(fams, chosen, q, r, reading_tr, train, w_tr, known):
    """The group with the largest BIC drop when added to the fit whose column basis is ``q``
    and whose whitened residual is ``r`` (periods refined around the grid's best): ``(spec,
    drop of χ², its columns' count, BIC drop)``, or ``None`` for an empty library."""
    n_tr = r.size
    chi2_now, p_now = float(r @ r), q.shape[1]
    best = None
    k = reading_tr.shape[1]
    same_width = [[s for s in f if s not in chosen and (s.leg is None) == every]
                  for f in fams for every in (True, False)]
    for fam in same_width:
        if not fam:
            continue
        drops = _family_drops(fam, q, r, reading_tr, train, w_tr)
        for spec, drop in zip(fam, drops, strict=True):
            df = _n_coef(spec) * len(_legs(spec, k))
            gain = bic(chi2_now, p_now, n_tr, known) - bic(chi2_now - drop, p_now + df, n_tr, known)
            if best is None or gain > best[3]:
                best = (spec, float(drop), df, gain)
    if best is not None and best[0].form == "periodic":
        spec, drop, df, gain = best
        grid = spec.period * np.linspace(1 - 2 * (PERIOD_RATIO - 1), 1 + 2 * (PERIOD_RATIO - 1), 41)
        drops = _family_drops([spec._replace(period=float(p)) for p in grid], q, r, reading_tr, train, w_tr)
        i = int(np.argmax(drops))
        spec, drop = spec._replace(period=float(grid[i])), drops[i]
        best = (spec, drop, df, bic(chi2_now, p_now, n_tr, known) - bic(chi2_now - drop, p_now + df, n_tr, known))
    return best


BIC_MARGIN = 6.0
"""A BIC difference above this is strong evidence (Kass and Raftery 1995, "Bayes factors", J.
Amer. Statist. Assoc. 90, §3.2)."""


def challenge(
    *,
    model: Any,
    train: Any,
    reading_tr: np.ndarray,
    white_tr: np.ndarray,
    w_tr: np.ndarray,
    jac_base: np.ndarray,
    jac_effect: np.ndarray,
    dof0: int,
    known: bool,
    alpha: float,
) -> tuple[str, TermSpec] | None:
    """Whether the open library's best group ``g`` contests a candidate ``a`` that passed the
    held-out test: ``("better", g)`` when ``g`` fits better by more than :data:`BIC_MARGIN`
    while ``a`` adds nothing significant (at ``alpha``) on top of ``g``; ``None`` otherwise (also
    when ``g`` lies in the span of the base and ``a``: the candidate is its physics).

    NOTE: a test of "``g`` adds to ``a``" is not used: on strong signals (gaps of 10× the noise
    and more) it rejected correct candidates that pass the held-out test, on the training
    residual's second-order misfit."""
    reading_tr = reading_tr * reading_factor(model)[0]
    k = reading_tr.shape[1]
    fams = _library(reading_tr, train, k, model.open_search_periodic)
    n_tr = white_tr.size
    q_g = basis(jac_base)
    r0 = white_tr - q_g @ (q_g.T @ white_tr)
    best = best_group(fams, [], q_g, r0, reading_tr, train, w_tr, known)
    if best is None:
        return None
    spec = best[0]
    cols = _columns(spec, reading_tr, train, w_tr)

    def chi2_rank(*blocks):
        q = basis(np.concatenate(blocks, axis=1))
        res = white_tr - q @ (q.T @ white_tr)
        return float(res @ res), q.shape[1]

    chi2_0, rank_0 = float(r0 @ r0), q_g.shape[1]
    chi2_a, rank_a = chi2_rank(jac_base, jac_effect)
    chi2_g, rank_g = chi2_rank(jac_base, cols)
    chi2_ag, rank_ag = chi2_rank(jac_base, jac_effect, cols)
    df_g, df_a = rank_ag - rank_a, rank_ag - rank_g
    if df_g == 0:
        return None
    dof = n_tr - rank_ag
    gain_a = bic(chi2_0, rank_0, n_tr, known) - bic(chi2_a, rank_a, n_tr, known)
    gain_g = bic(chi2_0, rank_0, n_tr, known) - bic(chi2_g, rank_g, n_tr, known)
    if gain_g > gain_a + BIC_MARGIN and nested_p(chi2_g, chi2_ag, df_a, dof, known) >= alpha:
        return "better", spec
    return None


def discover(
    *,
    model: Any,
    train: Any,
    test: Any,
    reading_tr: np.ndarray,
    reading_te: np.ndarray,
    white_tr: np.ndarray,
    white_te: np.ndarray,
    raw_te: np.ndarray,
    w_tr: np.ndarray,
    w_te: np.ndarray,
    jac_tr: np.ndarray,
    jac_te: np.ndarray,
    dof0: int,
    scale2: float,
    known: bool,
    alpha: float,
) -> list[TermSpec]:
    """Forward sparse selection of term groups (see the module docstring) on one data set.

    Inputs (whitened with the base fit's whiteners ``w_tr``/``w_te``, ``(m, k, k)``): the
    base fit's training and held-out residuals ``white_tr``/``white_te`` (flattened), its
    held-out raw residuals ``raw_te`` ``(m_te, k)`` (library units), the base Jacobians
    ``jac_tr``/``jac_te`` (scaled base unknowns), the readings ``reading_tr``/``reading_te``
    (library unit), the base fit's residual dof and noise scale. Returns the selected groups in
    the order chosen (whether each earns its place is decided in ``_term_ensemble.py``)."""
    scale = reading_factor(model)[0]
    reading_tr, reading_te = reading_tr * scale, reading_te * scale
    k = reading_tr.shape[1]
    n_tr, n_te = white_tr.size, white_te.size
    fams = _library(reading_tr, train, k, model.open_search_periodic)
    n_groups = sum(len(f) for f in fams)
    level = alpha / max(n_groups, 1)
    chosen: list[TermSpec] = []
    c_tr = np.zeros((n_tr, 0))
    c_te = np.zeros((n_te, 0))
    for _ in range(MAX_TERMS):
        a_tr = np.concatenate([jac_tr, c_tr], axis=1)
        q = basis(a_tr)
        r = white_tr - q @ (q.T @ white_tr)
        chi2_now = float(r @ r)
        p_now = q.shape[1]
        best = best_group(fams, chosen, q, r, reading_tr, train, w_tr, known)
        if best is None:
            break
        spec, drop, df, gain = best
        p = nested_p(chi2_now, chi2_now - drop, df, n_tr - p_now - df, known)
        if gain <= 0 or p >= level:
            break
        chosen.append(spec)
        c_tr = np.concatenate([c_tr, _columns(spec, reading_tr, train, w_tr)], axis=1)
        c_te = np.concatenate([c_te, _columns(spec, reading_te, test, w_te)], axis=1)
        a_tr = np.concatenate([jac_tr, c_tr], axis=1)
        a_te = np.concatenate([jac_te, c_te], axis=1)
        sol = np.linalg.lstsq(a_tr, -white_tr, rcond=None)[0]
        # r(z + δ) ≈ r + J δ; the terms enter as + C c with c = −(coefficient): see _columns.
        r_te = white_te + a_te @ sol
        t = heldout_chi2(r_te, a_tr, a_te)
        if heldout_p(t, n_te, dof0, scale2, known) >= alpha:
            break
    return chosen
