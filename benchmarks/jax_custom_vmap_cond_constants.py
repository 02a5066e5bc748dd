"""A ``custom_vmap`` function that creates an array constant fails under ``vmap`` of a ``lax.cond``
(jax 0.10.2), and the project's workaround.

jax 0.10's ``jax.custom_batching.custom_vmap`` traces its function once and hoists every array
constant the trace creates (a ``np.array([...])`` in the function body) into constants of the call.
Its batching rule then asserts that none of those constants is batched
(``assert not any(tree_leaves(consts_batched))``, ``jax/_src/custom_batching.py``). ``lax.cond``
under ``vmap`` with a batched predicate turns into a select of both branches and broadcasts every
operand of the branches to the batch, the hoisted constants included, so the assertion fires with
a bare ``AssertionError: [True]``. In the library this was the Nelder–Mead study crash: the
calibration objective (``population_objective``, a ``custom_vmap``) evaluated at one point inside
the solver's shrink-or-replace ``cond``, with the study's trials vmapped.

No upstream report was found for jax 0.10.2. ``jax_use_simplified_jaxpr_constants=True`` (a
transitional flag that JAX asks users not to rely on) also avoids it. The project's workaround is
the narrowest one: the ``custom_vmap`` function calls its body through ``jit``, whose own closed
jaxpr keeps the constants where no batching rule rewrites them.

    python benchmarks/jax_custom_vmap_cond_constants.py            # both arms, one line each
    python benchmarks/jax_custom_vmap_cond_constants.py --arm bare # exits 1 on an affected jax

Each arm prints ``<arm>: ok <values>`` or ``<arm>: AssertionError``; the script's exit status is 1
when the arm asked for (``--arm``) or, with ``--arm both``, the workaround arm fails.
"""

from __future__ import annotations

import argparse
import sys

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

WEIGHTS = (1.0, 2.0, 3.0)


def _body(x):
    return jnp.sum(x * np.array(WEIGHTS))  # an array constant created while tracing


def _rule(axis_size, in_batched, x):
    del axis_size, in_batched
    return jax.vmap(_body)(x), True


@jax.custom_batching.custom_vmap
def bare(x):
    return _body(x)


@jax.custom_batching.custom_vmap
def behind_jit(x):
    return jax.jit(_body)(x)


bare.def_vmap(_rule)
behind_jit.def_vmap(_rule)


def run(fn) -> np.ndarray:
    """``vmap`` over four predicates of a ``cond`` whose true branch calls ``fn`` at one point."""

    def per_member(a):
        return jax.lax.cond(a > 0, lambda: fn(a * jnp.ones(3)), lambda: 0.0 * a)

    return np.asarray(jax.vmap(per_member)(jnp.arange(4.0) - 1.0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--arm", choices=("bare", "jit", "both"), default="both")
    args = parser.parse_args(argv)
    arms = {"bare": bare, "jit": behind_jit}
    chosen = arms if args.arm == "both" else {args.arm: arms[args.arm]}
    expected = np.array([0.0, 0.0, 6.0, 12.0])  # a · Σ weights where a > 0, else 0
    failed = {}
    for name, fn in chosen.items():
        try:
            values = run(fn)
        except AssertionError:
            print(f"{name}: AssertionError (custom_vmap's hoisted constant batched by cond) on jax {jax.__version__}")
            failed[name] = True
            continue
        ok = bool(np.allclose(values, expected))
        failed[name] = not ok
        print(f"{name}: {'ok' if ok else 'WRONG'} {values.tolist()} on jax {jax.__version__}")
    decisive = "jit" if args.arm == "both" else args.arm
    return 1 if failed[decisive] else 0


if __name__ == "__main__":
    sys.exit(main())
