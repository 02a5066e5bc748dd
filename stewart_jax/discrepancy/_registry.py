"""Candidate effects and the model abstraction of the discrepancy workflow.

The workflow (:func:`~stewart_jax.discrepancy.diagnose`) knows nothing about Stewart platforms. It needs a *model*
(:class:`AbstractDiscrepancyModel`): base parameters, a prediction of the observations
from the base parameters and a set of *effects*, and a noise model that whitens the
residual of one data row. An *effect* (:class:`Effect`) is a small registered function

    apply(theta, data, state) -> state

that changes the model's intermediate state (for the 6-PSS model: the true poses, slider
axes, rod lengths, or the map from true stroke to encoder reading). ``theta = 0`` must leave
the state unchanged, so that the base model is the augmented model at ``theta = 0`` and
effects compose (the workflow fits effect pairs to tell candidates apart).

A new effect is one decorated function::

    @register_effect("6-pss", "my_effect", n_params=6, scale=1e-3, unit="mm")
    def my_effect(theta, data, state):
        '''Physics, parameters, units.'''
        return state._replace(offset=state.offset + theta)

The same function is what the hidden-effect simulator
(:func:`~stewart_jax.discrepancy.simulate_hidden_effect`) evaluates at the true parameters to
produce the readings, so a registered effect is simulated, diagnosed, listed by the command
line and tested without editing any list. ``draw`` optionally replaces the simulator's default
random direction of the true parameters (standard normal × ``scale``).

A second model (the FAST dynamics of Yin, Jiang, Chen, Yao, "Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST") plugs in by subclassing
:class:`AbstractDiscrepancyModel` and registering effects under its own model name.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence
from typing import Any, ClassVar, Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

_REGISTRY: dict[str, dict[str, Effect]] = {}


class Effect(eqx.Module):
    """A registered candidate effect (a parametric extension of a model).

    **Fields** (all static: an effect is a definition, not data):

    - ``name``: the canonical name.
    - ``model``: the name of the model it extends.
    - ``n_params``: number of parameters ``k``.
    - ``apply``: ``(theta: Float[Array, "k"], data, state) -> state``; pure, jittable,
      identity at ``theta = 0``.
    - ``scale``: typical magnitude of each parameter (library units), length ``k``; the fits
      work in ``theta / scale`` so that every unknown is O(1).
    - ``unit``: unit of the parameters in reports (``report_factor`` converts from library
      units).
    - ``requires``: data columns the effect needs (a candidate whose column is missing is
      skipped and reported).
    - ``acts_on``: ``"mechanism"`` (changes what the machine does; kept when the model is used
      for control) or ``"measurement"`` (changes only how it is observed; dropped for control).
    - ``draw``: ``(rng: numpy.random.Generator) -> Float[np.ndarray, "k"]``, the random
      direction of the true parameters a simulation hides (library units; its size is rescaled
      to the requested magnitude); ``None``: ``rng.standard_normal(k) · scale``.
    - ``doc``: the physics, from the function's docstring.
    - ``terms``: for the open search's effect, its terms (``DiscoveredTerms``: what a model file
      writes to rebuild the effect); ``None`` for a registered effect.
    """

    name: str = eqx.field(static=True)
    model: str = eqx.field(static=True)
    n_params: int = eqx.field(static=True)
    apply: Callable[..., Any] = eqx.field(static=True)
    scale: tuple[float, ...] = eqx.field(static=True)
    unit: str = eqx.field(static=True, default="")
    report_factor: tuple[float, ...] = eqx.field(static=True, default=())
    requires: tuple[str, ...] = eqx.field(static=True, default=())
    acts_on: Literal["mechanism", "measurement"] = eqx.field(static=True, default="mechanism")
    doc: str = eqx.field(static=True, default="")
    draw: Callable[[np.random.Generator], np.ndarray] | None = eqx.field(static=True, default=None)
    terms: Any = eqx.field(static=True, default=None)

    def random_direction(self, rng: np.random.Generator) -> Float[np.ndarray, " k"]:
        """A random direction of the true parameters (library units) for a simulation."""
        if self.draw is None:
            return rng.standard_normal(self.n_params) * np.asarray(self.scale)
        d = np.asarray(self.draw(rng), dtype=np.float64)
        if d.shape != (self.n_params,):
            raise ValueError(f"effect {self.name!r}: draw must return {self.n_params} values, got {d.shape}")
        return d

    def __call__(self, theta: Float[Array, " k"], data: Any, state: Any) -> Any:
        return self.apply(theta, data, state)


def register_effect(
    model: str,
    name: str,
    *,
    n_params: int,
    scale: float | Sequence[float],
    unit: str = "",
    report_factor: float | Sequence[float] = 1.0,
    requires: Sequence[str] = (),
    acts_on: Literal["mechanism", "measurement"] = "mechanism",
    draw: Callable[[np.random.Generator], np.ndarray] | None = None,
) -> Callable[[Callable[..., Any]], Effect]:
    """Decorator: register ``apply(theta, data, state) -> state`` as effect ``name`` of
    ``model`` (the fields are those of :class:`Effect`). Returns the :class:`Effect`.
    Re-registering a name replaces it."""
    if n_params < 1:
        raise ValueError(f"effect {name!r}: n_params must be ≥ 1")
    if acts_on not in ("mechanism", "measurement"):
        raise ValueError(f"effect {name!r}: acts_on must be 'mechanism' or 'measurement'")

    def per_param(x, what):
        t = tuple(float(v) for v in np.broadcast_to(np.asarray(x, dtype=np.float64), (n_params,)))
        if not all(np.isfinite(v) and v > 0 for v in t):
            raise ValueError(f"effect {name!r}: {what} must be positive, got {x}")
        return t

    scales, factors = per_param(scale, "scale"), per_param(report_factor, "report_factor")

    def decorator(fn: Callable[..., Any]) -> Effect:
        effect = Effect(
            name=name,
            model=model,
            n_params=n_params,
            apply=fn,
            scale=scales,
            unit=unit,
            report_factor=factors,
            requires=tuple(requires),
            acts_on=acts_on,
            doc=(fn.__doc__ or "").strip(),
            draw=draw,
        )
        _REGISTRY.setdefault(model, {})[name] = effect
        return effect

    return decorator


def register_again(effect: Effect, model: str, apply: Callable[..., Any] | None = None) -> Effect:
    """Register ``effect``'s definition (parameters, scales, units, columns, side, draw) under
    ``model`` too: for an effect whose physics holds unchanged for another model (``apply``
    ``None``: the same function), or whose function is adapted to that model's state."""
    fn = effect.apply if apply is None else apply
    if not fn.__doc__:
        fn.__doc__ = effect.doc
    return register_effect(model, effect.name, n_params=effect.n_params, scale=effect.scale, unit=effect.unit,
                           report_factor=effect.report_factor, requires=effect.requires, acts_on=effect.acts_on,
                           draw=effect.draw)(fn)


def effects_for(model: str) -> tuple[Effect, ...]:
    """Every effect registered for ``model``, in registration order."""
    return tuple(_REGISTRY.get(model, {}).values())


def effect_names(model: str) -> tuple[str, ...]:
    """Names of the effects registered for ``model``, in registration order."""
    return tuple(_REGISTRY.get(model, {}))


def get_effect(model: str, name: str) -> Effect:
    """The effect ``name`` of ``model``; a clear error listing the known names otherwise."""
    try:
        return _REGISTRY[model][name]
    except KeyError:
        known = sorted(_REGISTRY.get(model, {}))
        raise ValueError(f"no effect {name!r} registered for model {model!r}; known: {known}") from None


class AbstractDiscrepancyModel(eqx.Module):
    """A model the discrepancy workflow can question.

    Data are rows (poses, time steps) of ``k`` observations each. Subclasses define:

    - ``name`` (class variable): the registry key of its effects.
    - ``base_initial`` / ``base_scale``: starting base parameters ``Float[Array, "p"]`` and
      their typical uncertainty (the fits work in ``(u − u0) / scale``).
    - ``observed(data) -> Float[Array, "m k"]``: the measured observations.
    - ``initial_state(base, data, control) -> state`` and ``finish(state, data) ->
      Float[Array, "m k"]``: the prediction, with effects applied to ``state`` in between.
    - ``whitener(base, data) -> Float[Array, "m k k"]``: per row ``W_j`` with
      ``W_j (y_j − ŷ_j) ~ N(0, I)`` under the model's noise alone.
    - ``columns(data)``: names of the optional columns present (for ``Effect.requires``).
    - ``n_rows(data)``, ``take(data, index)``: row count and row selection.
    - ``factors(data) -> dict[str, Float[np.ndarray, "m k"]]``: quantities to plot the
      residuals against ("where does the model disagree").
    - ``output_names``, ``report_unit``, ``report_factor``: labels of the ``k`` observations,
      and the unit/conversion for reported residuals.
    """

    name: ClassVar[str]
    output_names: ClassVar[tuple[str, ...]]
    report_unit: ClassVar[str]
    report_factor: ClassVar[float]
    fit_steps: ClassVar[int | None] = None
    """Gauss–Newton steps of the augmented fits (``None``: the workflow's default)."""
    open_search: ClassVar[bool] = False
    """Whether the open term search runs on this model (its state then has an additive
    ``offset`` of the outputs, and its data follow ``_discovery.SearchData``: ``time``,
    ``time_unit``, ``directions``, ``temperature``, ``poses``, each ``None`` where absent)."""
    batched_fits: ClassVar[bool] = True
    """Whether many data sets may be fitted in one batch. ``False`` for a model whose fits hold
    LAPACK calls that, batched, deadlock jaxlib 0.10's CPU thread pool (see
    ``stewart_jax/_linalg.py``): its data sets are fitted one at a time."""
    open_search_periodic: ClassVar[tuple[str, ...]] = ("reading",)
    """The factors whose periodic terms the open search offers (``"reading"``: the actuator
    readings; ``"time"``: the record's time)."""
    output_noun: ClassVar[str] = "actuator"
    """What one output is called in the names of the open search's terms: ``"actuator"``
    (numbered from 1), or another noun, and then the outputs are named by ``output_names``."""
    output_units: ClassVar[tuple[str, ...] | None] = None
    """The unit of each output as a factor of the open search; ``None``: the readings' factor
    unit (mm, or degrees for a crank angle: ``_discovery.reading_factor``)."""
    output_report_units: ClassVar[tuple[str, ...] | None] = None
    """The report unit of each output's residual; ``None``: :attr:`report_unit` for every one."""
    time_unit: ClassVar[str] = "h"
    """The unit of the open search's ``time`` factor in term names (hours for a session)."""
    file_columns: ClassVar[dict[str, str]] = {"directions": "dir1..dir6", "temperature": "temperature",
                                              "time": "time"}
    """The data file's column(s) behind each condition an effect ``requires``, as a user finds
    them in the file (a skipped candidate names these)."""

    @property
    def reading_unit(self) -> str:
        """The library unit of the readings (``"mm"``; a mechanism's model: its mechanism's
        ``reading_unit``)."""
        return "mm"

    @property
    def base_names(self) -> tuple[str, ...]:
        """Labels of the base parameters; ``()``: the workflow numbers them (a mechanism's
        model: its mechanism's ``param_names``)."""
        return ()

    def effect_grid(self, effects: Sequence[Effect]) -> np.ndarray | None:
        """Optional: starting points for the augmented fits of an effect whose prediction is far
        from linear in its parameters (a change of frequency over a long record): rows of the
        effects' scaled unknowns ``θ / scale`` (``Float[np.ndarray, "s n_effects"]``, all the
        effects' parameters concatenated, a row of zeros included). Each fit first fits the base
        parameters at every row and starts from the best. ``None`` (default): start at θ = 0."""
        return None

    @property
    @abc.abstractmethod
    def base_initial(self) -> Float[Array, " p"]: ...

    @property
    @abc.abstractmethod
    def base_scale(self) -> Float[Array, " p"]: ...

    @abc.abstractmethod
    def observed(self, data: Any) -> Float[Array, "m k"]: ...

    @abc.abstractmethod
    def initial_state(self, base: Float[Array, " p"], data: Any, control: bool) -> Any: ...

    @abc.abstractmethod
    def finish(self, state: Any, data: Any) -> Float[Array, "m k"]: ...

    @abc.abstractmethod
    def whitener(self, base: Float[Array, " p"], data: Any) -> Float[Array, "m k k"]: ...

    @abc.abstractmethod
    def columns(self, data: Any) -> frozenset[str]: ...

    @abc.abstractmethod
    def n_rows(self, data: Any) -> int: ...

    @abc.abstractmethod
    def take(self, data: Any, index: Any) -> Any: ...

    @abc.abstractmethod
    def factors(self, data: Any) -> dict[str, np.ndarray]: ...

    def derived_errors(self, base: Float[Array, " p"], data: Any, residuals: np.ndarray) -> dict[str, np.ndarray]:
        """Optional: residuals (``m k``, library units) mapped to quantities a user judges the
        model by, in report units (e.g. pose errors); name → ``(m,)`` array."""
        return {}

    def predict(
        self,
        base: Float[Array, " p"],
        effects: Sequence[Effect],
        thetas: Sequence[Float[Array, " _"]],
        data: Any,
        control: bool = False,
    ) -> Float[Array, "m k"]:
        """Observations predicted by the base model extended by ``effects`` (parameters
        ``thetas``, library units). With ``control=True`` measurement-side effects are dropped:
        the prediction is then what to command to reach the poses in ``data``."""
        state = self.initial_state(base, data, control)
        for effect, theta in zip(effects, thetas, strict=True):
            if control and effect.acts_on == "measurement":
                continue
            state = effect(jnp.asarray(theta), data, state)
        return self.finish(state, data)
