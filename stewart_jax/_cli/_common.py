"""Helpers shared by the subcommands."""

from __future__ import annotations

import argparse

_INPUTS = {"file": "data file", "geometry": "--geometry", "true": "--true", "points": "--points"}
"""Arguments that may name an input file: no output may overwrite one."""


def check_outputs(args: argparse.Namespace, **outputs: str) -> None:
    """Every output path given (``attribute=description``) can be written, no two of them are
    one file and none is an input file: checked before any work, so that a typo in a path costs
    nothing and no output destroys another (a checkpoint replaced by the result). An existing
    file an output replaces is kept as ``PATH.bak`` first (:func:`_keep_replaced`)."""
    from .._files import check_distinct_paths, check_writable

    for attr, what in outputs.items():
        path = getattr(args, attr, None)
        if path:
            check_writable(path, what)
    inputs = {what: getattr(args, attr, None) for attr, what in _INPUTS.items()}
    check_distinct_paths({what: getattr(args, attr, None) for attr, what in outputs.items()},
                         {k: v for k, v in inputs.items() if isinstance(v, str)})
    _keep_replaced(args, outputs)


def _keep_replaced(args: argparse.Namespace, outputs: dict[str, str]) -> None:
    """An existing file that an output will replace is copied to ``PATH.bak`` (``.bak1``, … where
    that exists) first, and the command says so: a generated file never silently replaces one
    that a person made or edited. A study's checkpoint is its own input (resumed, not replaced)."""
    import os
    import sys

    from .._files import keep_backup

    for attr, what in outputs.items():
        path = getattr(args, attr, None)
        if attr == "checkpoint" or not path or not os.path.isfile(path):
            continue
        print(f"{what} {path} exists: kept it as {keep_backup(path)} before replacing it", file=sys.stderr)


def write_json(path: str, obj) -> None:
    """``obj`` as strict JSON (non-finite numbers as ``null``), written atomically."""
    from .._files import json_text, write_text_atomic

    write_text_atomic(path, json_text(obj))


def file_backend() -> None:
    """``--plot`` only writes a file: the non-interactive backend, chosen before pyplot is
    imported (the library itself never chooses one)."""
    import matplotlib

    matplotlib.use("Agg")


def seed_key(seed: int):
    """``jax.random.key(seed)`` (the same key: threefry's seed of ``0 ≤ s < 2³²`` is the pair
    ``(0, s)``) without its two eager programs, which a warm command would otherwise look up."""
    import jax
    import numpy as np

    if 0 <= seed < 2**32 and jax.config.jax_default_prng_impl == "threefry2x32":
        return jax.random.wrap_key_data(np.array([0, seed], dtype=np.uint32), impl="threefry2x32")
    return jax.random.key(seed)


def noise_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sigma-um", type=float, default=0.1, help="pose noise σ, translation (µm)")
    p.add_argument("--sigma-arcsec", type=float, default=0.1, help="pose noise σ, angles (″)")


def geometry_args(p: argparse.ArgumentParser, *, true: bool) -> None:
    """``--geometry`` (the nominal model) and, for simulations, the true mechanism."""
    from ..mechanism._registry import presets

    p.add_argument("--geometry", "--nominal", dest="geometry", default="nominal",
                   help=f"nominal (model) geometry: a preset ({', '.join(presets())}) or a JSON/TOML geometry file")
    param_set_arg(p)
    if true:
        p.add_argument("--true", default=None,
                       help="true geometry (preset or file); default: the preset's measured geometry where one is "
                            "registered ('actual' for the paper's 'nominal'), else the nominal one perturbed by "
                            "--perturb-mm")
        p.add_argument("--perturb-mm", type=float, default=0.5,
                       help="σ (mm) of the Gaussian error on every length parameter of the default true mechanism")
        p.add_argument("--perturb-mrad", type=float, default=None,
                       help="σ (mrad) of the Gaussian error on every angle parameter of the default true mechanism "
                            "(default: the --perturb-mm number)")


def param_set_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--param-set", choices=("36", "42", "48", "54"),
                   help="calibration parameters: a 6-PSS's 36 joint centres (the paper's), + 6 rod lengths (42), "
                        "+ 12 slider-axis tilts in mrad (54); a 6-RUS's joints, cranks and rods (48), + 6 crank "
                        "zero angles in rad (54); default: what the geometry file implies")


def load_nominal(args: argparse.Namespace):
    """``--geometry``, with ``--param-set`` applied."""
    from ..mechanism._registry import load_mechanism

    nominal = load_mechanism(args.geometry)
    param_set = getattr(args, "param_set", None)
    if param_set is None:
        return nominal
    if param_set not in nominal.param_sets:
        sets = (f"the parameter sets {', '.join(nominal.param_sets)}" if nominal.param_sets
                else f"one fixed parameter set ({nominal.n_params} parameters)")
        raise ValueError(f"--param-set {param_set}: {args.geometry!r} is a {nominal.family}, which has {sets}")
    return nominal.with_param_set(param_set)


def nominal_and_true(args: argparse.Namespace):
    """The nominal and true mechanisms of ``--geometry``/``--true``/``--perturb-mm``."""
    import jax

    from ..calibration._simulation import perturbed
    from ..mechanism._registry import load_mechanism, measured_preset

    nominal = load_nominal(args)
    if args.true is not None:
        true = load_mechanism(args.true)
    elif measured_preset(args.geometry) is not None:
        true = load_mechanism(measured_preset(args.geometry))
    else:
        true = perturbed(nominal, jax.random.fold_in(seed_key(args.seed), 1_000_003), args.perturb_mm,
                         getattr(args, "perturb_mrad", None))
    if type(nominal) is not type(true):
        raise ValueError(f"--geometry is a {nominal.family}, --true a {true.family}: give one family")
    return nominal, true


CALIBRATION_KEY = "_calibration"
"""The calibrated geometry file's record of what the data support (a ``_`` key: the families ignore it)."""


def save_calibrated(path: str, nominal, calibrated, assessment, prior_scale) -> None:
    """Write the calibrated geometry with a ``_calibration`` record: the nominal parameters, each
    parameter's standard deviation about the truth (``null`` where the data do not support its
    value), its prior scale and the data status, which ``export`` checks (atomic)."""
    import json

    import numpy as np

    from .._files import write_text_atomic

    n = nominal.n_params
    std = np.asarray(assessment.param_std)[:n]
    d = calibrated.to_dict()
    d[CALIBRATION_KEY] = {
        "data_status": assessment.status,
        "param_names": list(nominal.param_names),
        "param_units": list(nominal.param_units),
        "nominal_params": [float(x) for x in np.asarray(nominal.params)],
        "param_std": [float(s) if np.isfinite(s) else None for s in std],
        "prior_scale": [float(s) for s in np.asarray(prior_scale)[:n]],
    }
    write_text_atomic(path, json.dumps(d, indent=2) + "\n")
