"""Keywords as changes to the library's settings (``Params``, nested as its serde form).

Every keyword defaults to None, meaning "the library's default" (what ``spincal calibrate``
runs); a keyword that is given becomes one entry of a dict of changes, which the library merges
into its defaults and checks (an unknown or unusable setting is refused with its path, e.g.
``network.restarts``). ``params=`` passes such a dict directly, for every other setting.
"""

from __future__ import annotations

import json
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

from . import _spincal
from ._spincal import UsageError

STANDARD_GRAVITY = 9.80665

Axes = Union[str, Sequence[str]]
Orders = Union[str, Sequence[int]]


def default_params() -> Dict[str, Any]:
    """The library's default settings (``Params``), as plain data: what ``spincal calibrate``
    runs; any part of it can be changed through ``params=``.

    Example::

        >>> p = spincal.default_params()
        >>> p["correct_axes"], p["network"]["mode"], p["fit"]["drift"]
        (['x', 'y'], 'sweep', 'fit')
    """
    return json.loads(_spincal.default_params())


def _deep_update(into: Dict[str, Any], changes: Mapping[str, Any]) -> None:
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(into.get(key), dict):
            _deep_update(into[key], value)
        else:
            into[key] = value


def axes_list(value: Axes, what: str) -> list:
    """``["x", "y"]`` (or ``"xy"``, ``"x,y"``) as the library's axis names."""
    items = list(value.replace(",", "")) if isinstance(value, str) else list(value)
    names = [str(a).strip().lower() for a in items]
    if not names or any(a not in ("x", "y", "z") for a in names):
        raise UsageError(f"{what} {value!r}: expected axes among 'x', 'y', 'z', e.g. ['x', 'y']")
    return names


def orders_list(value: Orders, what: str) -> list:
    """``[6, 8, 1]`` (or ``"6,8,1"``) as a list of non-negative integers."""
    items = value.split(",") if isinstance(value, str) else list(value)
    try:
        orders = [int(str(o).strip()) for o in items]
    except ValueError:
        raise UsageError(f"{what} {value!r}: expected a list of whole numbers, e.g. [6, 8, 1]") from None
    if not orders or any(o < 0 for o in orders):
        raise UsageError(f"{what} {value!r}: expected a list of whole numbers, e.g. [6, 8, 1]")
    return orders


def fit_changes(
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: Optional[float] = None,
    objective_axes: Optional[str] = None,
    drift: Optional[bool] = None,
    fit_offsets: Optional[bool] = None,
    separate_radii: Optional[bool] = None,
    gravity_mps2: Optional[float] = None,
    range_g: Optional[float] = None,
    bounds: Optional[Mapping[str, Tuple[float, float]]] = None,
) -> Dict[str, Any]:
    """The turntable fit's keywords as changes to ``Params.fit``."""
    fit: Dict[str, Any] = {}
    if rpm is not None:
        fit["rpm_hint"] = float(rpm)
    if radius_m is not None:
        fit["radius"] = {"value_m": float(radius_m), "tolerance_m": float(0.002 if radius_tol_m is None else radius_tol_m)}
    elif radius_tol_m is not None:
        raise UsageError("radius_tol_m is the tolerance of radius_m: give radius_m too")
    if objective_axes is not None:
        fit["axes"] = "".join(axes_list(objective_axes, "objective_axes"))
    if drift is not None:
        fit["drift"] = "fit" if drift else "off"
    if fit_offsets is not None:
        fit["fit_offsets"] = bool(fit_offsets)
    if separate_radii is not None:
        fit["shared_radius"] = not separate_radii
    if gravity_mps2 is not None:
        fit["gravity_mps2"] = float(gravity_mps2)
    if range_g is not None:
        fit["range_mps2"] = float(range_g) * STANDARD_GRAVITY
    if bounds:
        fit["bounds"] = [[str(k), float(lo), float(hi)] for k, (lo, hi) in bounds.items()]
    return fit


def calibration_changes(
    params: Optional[Mapping[str, Any]],
    fit: Dict[str, Any],
    *,
    sweep: Optional[str],
    hidden: Optional[Orders],
    restarts: Optional[int],
    sweep_hessian_samples: Optional[int],
    correct_axes: Optional[Axes],
    delays: Optional[int],
    seed: Optional[int],
) -> Dict[str, Any]:
    """The calibration's keywords (and ``params``) as one dict of changes to ``Params``."""
    changes: Dict[str, Any] = {}
    if params is not None:
        if not isinstance(params, Mapping):
            raise UsageError(f"params: expected a dict of settings, got {type(params).__name__}")
        changes = json.loads(json.dumps(dict(params)))
    if fit:
        _deep_update(changes.setdefault("fit", {}), fit)
    if sweep is not None and sweep not in ("none", "small", "full"):
        raise UsageError(f"sweep {sweep!r}: expected 'none', 'small' or 'full'")
    if hidden is not None and sweep in ("small", "full"):
        raise UsageError(
            f"hidden fixes the architecture, so it cannot be combined with sweep={sweep!r}; drop one of them"
        )
    given = changes.get("network", {})
    network: Dict[str, Any] = {}
    if hidden is not None or sweep == "none":
        layers = orders_list(hidden if hidden is not None else [10, 6], "hidden")
        if restarts is None:
            restarts = given.get("restarts", default_params()["network"]["restarts"])
        network = {"mode": "fixed", "hidden": layers, "restarts": restarts}
    elif sweep is not None or sweep_hessian_samples is not None:
        network = {"mode": "sweep"}
        if sweep is not None:
            network["grid"] = _spincal.sweep_grid(sweep)
        if sweep_hessian_samples is not None:
            network["hessian_samples"] = None if sweep_hessian_samples == 0 else int(sweep_hessian_samples)
    if restarts is not None:
        network["restarts"] = int(restarts)
    if network:
        if given.get("mode", network.get("mode")) == network.get("mode", given.get("mode")):
            changes["network"] = {**given, **network}
        else:
            changes["network"] = network
    if correct_axes is not None:
        changes["correct_axes"] = axes_list(correct_axes, "correct_axes")
    if delays is not None:
        changes["delays"] = int(delays)
    if seed is not None:
        changes["seed"] = int(seed)
    return changes
