"""Which discrepancy model questions which mechanism family, and the file of a fitted model.

Each mechanism family with a discrepancy model registers it once::

    register_model_family("6-UPS", "6-ups", ups_model)

with the family's name (``mechanism.family``), the model's name (the key its effects are
registered under), the factory ``(mechanism, sigma_um, sigma_arcsec, sigma_reading) -> model``
(the reading noise in µm for a linear family, µrad for a rotary one) and, optionally,
``(model, base) -> mechanism``, the mechanism whose calibration parameters are ``base`` (default:
the model's ``mechanism`` with its parameters replaced).
:func:`model_for` then builds the model of any registered family, and the hidden-effect
simulator, the command line and :func:`save_fitted_model`/:func:`load_fitted_model` dispatch
through it. The 6-PSS model (Wang et al. 2018, "Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5)), the
6-UPS strut model and the 6-RUS rotary model register themselves here.

Every model registered here has the pose-noise fields ``sigma_mm`` and ``sigma_rad`` (mm, rad)
and a reading noise ``reading_sigma`` (the reading's unit), which the model file records
(``sigma_stroke_um`` for a linear family, ``sigma_reading_urad`` for a rotary one).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from typing import Any, NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._units import ARCSEC, UM
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._registry import mechanism_from_dict
from ._registry import AbstractDiscrepancyModel, get_effect


class ModelFamily(NamedTuple):
    """A registered family → model pairing (see the module docstring)."""

    family: str
    model_name: str
    factory: Callable[[AbstractMechanism, float, float, float], AbstractDiscrepancyModel]
    mechanism: Callable[[AbstractDiscrepancyModel, Float[Array, " p"]], AbstractMechanism]


_FAMILIES: dict[str, ModelFamily] = {}


def _with_base(model: Any, base: Float[Array, " p"]) -> AbstractMechanism:
    return model.mechanism.with_params(base)


def register_model_family(
    family: str,
    model_name: str,
    factory: Callable[[AbstractMechanism, float, float, float], AbstractDiscrepancyModel],
    mechanism: Callable[[AbstractDiscrepancyModel, Float[Array, " p"]], AbstractMechanism] | None = None,
) -> ModelFamily:
    """Register the discrepancy model of mechanism family ``family`` (re-registering replaces).
    ``mechanism(model, base)``: the mechanism of fitted base parameters ``base``; default the
    model's own ``mechanism`` with its parameters replaced (every ``AbstractMechanismModel``)."""
    entry = ModelFamily(family, model_name, factory, _with_base if mechanism is None else mechanism)
    _FAMILIES[family] = entry
    return entry


def model_families() -> dict[str, str]:
    """Mechanism family → name of its discrepancy model, for every registered family."""
    return {f: e.model_name for f, e in _FAMILIES.items()}


def _entry_for_family(family: str) -> ModelFamily:
    try:
        return _FAMILIES[family]
    except KeyError:
        raise ValueError(
            f"the discrepancy workflow has no model for the {family} family; families with one: {sorted(_FAMILIES)}"
        ) from None


def _entry_for_model(model_name: str) -> ModelFamily:
    for e in _FAMILIES.values():
        if e.model_name == model_name:
            return e
    raise ValueError(
        f"no discrepancy model named {model_name!r}; known: {sorted(e.model_name for e in _FAMILIES.values())}"
    )


def model_name_for(family: str) -> str:
    """The name of the discrepancy model (and effect registry key) of mechanism family ``family``."""
    return _entry_for_family(family).model_name


def check_family(mechanism: Any, cls: type[AbstractMechanism], factory: str) -> None:
    """A clear error unless ``mechanism`` is a ``cls`` (the family the model ``factory`` builds)."""
    if not isinstance(mechanism, cls):
        got = mechanism.family if isinstance(mechanism, AbstractMechanism) else type(mechanism).__name__
        raise ValueError(f"{factory} needs a {cls.family} mechanism, got a {got}; model_for(mechanism) picks the "
                         "model of its family")


def check_noise(sigma_um: float, sigma_arcsec: float, sigma_reading: float,
                reading_name: str = "sigma_reading_um") -> None:
    """Clear errors for a noise model the whitener cannot invert: every σ finite and ≥ 0, and
    both pose σ > 0 unless the readings have noise of their own (``reading_name``: how the
    reading noise is called, with its unit: ``sigma_reading_um``, ``sigma_reading_urad``)."""
    for name, s in (("sigma_um", sigma_um), ("sigma_arcsec", sigma_arcsec), (reading_name, sigma_reading)):
        if not (np.isfinite(s) and s >= 0):
            raise ValueError(f"{name} must be a finite number ≥ 0, got {s}")
    if sigma_reading == 0 and (sigma_um == 0 or sigma_arcsec == 0):
        raise ValueError(
            "the reading-residual covariance J·Σ·Jᵀ is singular unless both pose sigmas are > 0 "
            f"(got sigma_um={sigma_um}, sigma_arcsec={sigma_arcsec}); give both, or {reading_name} > 0"
        )


def model_for(
    mechanism: AbstractMechanism, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, *,
    sigma_reading_um: float = 0.0, sigma_reading_urad: float = 0.0,
) -> AbstractDiscrepancyModel:
    """The discrepancy model of ``mechanism``'s family, starting from ``mechanism``, with pose noise
    σ (µm, ″) and the readings' own noise σ: ``sigma_reading_um`` for a family whose readings are
    lengths, ``sigma_reading_urad`` for one whose readings are angles (the other must stay 0); a
    clear error for a family without a model."""
    if not isinstance(mechanism, AbstractMechanism):
        raise TypeError(f"model_for needs a mechanism (e.g. stewart_jax.load_mechanism(...)), got {mechanism!r}")
    linear = mechanism.reading_unit == "mm"
    given, other = (sigma_reading_um, "sigma_reading_urad") if linear else (sigma_reading_urad, "sigma_reading_um")
    if (sigma_reading_urad if linear else sigma_reading_um) != 0:
        unit = "mm (lengths)" if linear else "rad (angles)"
        raise ValueError(f"{other} does not apply: a {mechanism.family}'s readings are in {unit}; give "
                         f"{'sigma_reading_um' if linear else 'sigma_reading_urad'}")
    return _entry_for_family(mechanism.family).factory(mechanism, sigma_um, sigma_arcsec, given)


def save_fitted_model(fitted, path: str | os.PathLike[str]) -> None:
    """Write a fitted (augmented) model as JSON: the model name and mechanism family, the
    calibration parameters (``params``) and ``v0`` (mm), the fitted mechanism's geometry file
    (``geometry``, with the family's limits and travel), the noise model, and each effect's name
    and parameters (library units: mm, rad, 1/K, mm/s; and in report units); discovered terms
    also carry their definition (``terms``)."""
    m = fitted.model
    entry = _entry_for_model(m.name)
    mechanism = entry.mechanism(m, jnp.asarray(fitted.base))
    out = {
        "model": m.name,
        "family": entry.family,
        "units": "mm",
        "params": np.asarray(fitted.base).tolist(),
        "v0": np.asarray(mechanism.v0).tolist(),
        "sigma_um": float(m.sigma_mm) / UM,
        "sigma_arcsec": float(m.sigma_rad) / ARCSEC,
        _reading_sigma_key(mechanism): float(m.reading_sigma) / (UM if mechanism.reading_unit == "mm" else 1e-6),
        "effects": [
            {"effect": e.name, "params": np.asarray(t).tolist(), "report_params": r["params"], "report_unit": e.unit}
            | ({"terms": e.terms.to_dict()} if e.terms is not None else {})
            for e, t, r in zip(fitted.effects, fitted.thetas, fitted.effect_report(), strict=True)
        ],
        "geometry": mechanism.to_dict(),
    }
    from .._files import json_text, write_text_atomic

    write_text_atomic(path, json_text(out))


def _reading_sigma_key(mechanism: AbstractMechanism) -> str:
    """The model file's key of the reading noise: ``sigma_stroke_um`` (linear readings) or
    ``sigma_reading_urad`` (angular)."""
    return "sigma_stroke_um" if mechanism.reading_unit == "mm" else "sigma_reading_urad"


def _legacy_pss_geometry(d: dict[str, Any]) -> dict[str, Any]:
    """The geometry of a 6-PSS model file written before files carried ``geometry``: the 36
    parameters (``Ac_1..Ac_6``, ``Bc_1..Bc_6``) and ``v0``."""
    p = np.asarray(d["params"], dtype=np.float64)
    if p.shape != (36,):
        raise ValueError(f"a 6-pss model file without 'geometry' must give 36 params, got {p.shape}")
    return {"mechanism": "6-PSS", "units": "mm", "upper": p[:18].reshape(6, 3).tolist(),
            "lower": p[18:].reshape(6, 3).tolist(), "v0": d.get("v0", (0.0, 0.0, 0.0))}


def load_fitted_model(path: str | os.PathLike[str]):
    """Inverse of :func:`save_fitted_model` for any registered family (and the 6-PSS files
    written before the family was recorded): a :class:`~stewart_jax.discrepancy.FittedModel`
    whose :meth:`commanded` gives the readings to command for target poses."""
    from ._report import FittedModel

    with open(path) as f:
        d = json.load(f)
    name = d.get("model")
    try:
        entry = _entry_for_model(name)
    except ValueError as err:
        raise ValueError(f"{path}: not a fitted discrepancy model file ({err})") from None
    if "params" not in d:
        raise ValueError(f"{path}: the model file has no 'params'")
    geometry = d.get("geometry")
    if geometry is None:
        if entry.family != "6-PSS":
            raise ValueError(f"{path}: a {entry.family} model file must carry its 'geometry'")
        geometry = _legacy_pss_geometry(d)
    mechanism = mechanism_from_dict(geometry)
    if mechanism.family != entry.family:
        raise ValueError(
            f"{path}: model {name!r} is for the {entry.family} family, its geometry is a {mechanism.family}"
        )
    params = np.asarray(d["params"], dtype=np.float64)
    if params.shape != (mechanism.n_params,):
        raise ValueError(
            f"{path}: a {entry.family} model has {mechanism.n_params} params, the file gives {params.shape}"
        )
    mechanism = mechanism.with_params(jnp.asarray(params))
    model = entry.factory(mechanism, d.get("sigma_um", 0.1), d.get("sigma_arcsec", 0.1),
                          d.get(_reading_sigma_key(mechanism), 0.0))
    from ._discovery import DiscoveredTerms

    effects = tuple(
        DiscoveredTerms.from_dict(e["terms"]).effect(model) if "terms" in e else get_effect(name, e["effect"])
        for e in d.get("effects", [])
    )
    thetas = tuple(jnp.asarray(e["params"], dtype=jnp.float64) for e in d.get("effects", []))
    for e, t in zip(effects, thetas, strict=True):
        if t.shape != (e.n_params,):
            raise ValueError(f"{path}: effect {e.name!r} needs {e.n_params} parameters, got {t.shape}")
    return FittedModel(model, effects, model.base_initial, thetas)
