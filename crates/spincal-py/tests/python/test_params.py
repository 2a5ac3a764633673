"""Settings as Python values, merged into the library's Params; results with parameters by name."""

import json
import re

import numpy as np
import pytest

import spincal
from spincal import _spincal


def _untimed(value):
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def _resolved(changes):
    return json.loads(_spincal.resolve_params(json.dumps(changes)))


def _cli_defaults(cli):
    """The defaults `spincal calibrate --help` states, by flag: declared in the CLI's arguments,
    apart from the library's Params::default."""
    text = " ".join(cli("calibrate", "--help").stdout.split())
    # A flag, its help (which names no other flag's start), then its default.
    found = dict(re.findall(r"--([a-z-]+) <[A-Z_]+>(?:(?! --[a-z])[^\[])*\[default: ([^\]]+)\]", text))
    assert {"restarts", "correct-axes", "delays", "seed", "arx", "bj", "narx", "hw"} <= found.keys(), found
    return found


def test_default_params_are_the_stated_ones(cli):
    defaults = spincal.default_params()
    # What the Python package hands out is what the library resolves from no changes at all.
    assert defaults == _resolved({})
    # The grids computed here from their stated rules: the small one (one hidden layer of 1–8
    # units, two of 2–8 × 2–6 in even sizes) and the paper's (1–15, then 1–15 × 1–10: 165).
    small = [[n] for n in range(1, 9)] + [[a, b] for a in range(2, 9, 2) for b in range(2, 7, 2)]
    full = [[n] for n in range(1, 16)] + [[a, b] for a in range(1, 16) for b in range(1, 11)]
    assert len(full) == 165
    assert _spincal.sweep_grid("small") == small and _spincal.sweep_grid("full") == full
    network = defaults["network"]
    assert network["mode"] == "sweep" and network["grid"] == small
    # Every default the CLI states for `calibrate` is the library's.
    stated = _cli_defaults(cli)
    assert network["restarts"] == int(stated["restarts"])
    assert network["hessian_samples"] == int(stated["sweep-hessian-samples"])
    assert defaults["correct_axes"] == stated["correct-axes"].split(",")
    assert defaults["delays"] == int(stated["delays"]) and defaults["seed"] == int(stated["seed"])
    orders = {spec["kind"]: spec["orders"] for spec in defaults["sysid"]}
    assert orders == {kind: [int(v) for v in stated[kind].split(",")] for kind in ["arx", "bj", "narx", "hw"]}


def test_keywords_are_python_values_and_equal_the_params_dict():
    from spincal._params import calibration_changes, fit_changes

    changes = calibration_changes(
        None,
        fit_changes(radius_m=0.1, drift=False),
        sweep=None,
        hidden=[10, 6],
        restarts=2,
        sweep_hessian_samples=None,
        correct_axes=["x", "z"],
        delays=1,
        seed=9,
    )
    resolved = _resolved(changes)
    assert resolved["network"] == {"mode": "fixed", "hidden": [10, 6], "restarts": 2}
    assert resolved["correct_axes"] == ["x", "z"] and resolved["delays"] == 1 and resolved["seed"] == 9
    assert resolved["fit"]["radius"] == {"value_m": 0.1, "tolerance_m": 0.002}
    assert resolved["fit"]["drift"] == "off"
    # Everything not named stays the library's default.
    defaults = spincal.default_params()
    for key in ["lm", "division", "sysid", "joint", "gyro", "candidates"]:
        assert resolved[key] == defaults[key], key
    # The old text forms still read the same.
    same = calibration_changes(
        None, {}, sweep=None, hidden="10,6", restarts=2, sweep_hessian_samples=None, correct_axes="x,z", delays=None, seed=None
    )
    assert _resolved(same)["network"] == resolved["network"] and _resolved(same)["correct_axes"] == ["x", "z"]
    full = calibration_changes(
        None, {}, sweep="full", hidden=None, restarts=None, sweep_hessian_samples=0, correct_axes=None, delays=None, seed=None
    )
    network = _resolved(full)["network"]
    assert len(network["grid"]) == 165 and network["hessian_samples"] is None and network["restarts"] == 3


def test_unknown_or_unusable_settings_are_named_by_their_path():
    rec, _ = spincal.simulate(seed=2, turntable={"duration_s": 5.0})
    with pytest.raises(spincal.UsageError, match=r"fit\.gravty_mps2.*gravity_mps2"):
        spincal.calibrate([rec], params={"fit": {"gravty_mps2": 9.8}})
    with pytest.raises(spincal.UsageError, match=r"network\.restarts"):
        spincal.calibrate([rec], hidden=[3], restarts=0)
    with pytest.raises(spincal.UsageError, match=r"correct_axes"):
        spincal.calibrate([rec], correct_axes=["x", "w"])
    with pytest.raises(spincal.UsageError, match=r"hidden fixes the architecture"):
        spincal.calibrate([rec], sweep="full", hidden=[4])
    with pytest.raises(spincal.UsageError, match=r"arx.*orders"):
        spincal.calibrate([rec], arx=[1])
    with pytest.raises(spincal.UsageError, match=r"fit\.radius\.value_m"):
        spincal.fit_turntable([rec], radius_m=-1.0)


def test_keywords_and_params_give_the_same_calibration():
    rec, _ = spincal.simulate(seed=8, turntable={"duration_s": 20.0})
    by_keywords = spincal.calibrate([rec], radius_m=0.1, hidden=[3], restarts=1, correct_axes=["x"], arx=[2, 2, 1])
    by_params = spincal.calibrate(
        [rec],
        params={"fit": {"radius": {"value_m": 0.1, "tolerance_m": 0.002}}, "network": {"mode": "fixed", "hidden": [3], "restarts": 1}, "correct_axes": ["x"]},
        arx="2,2,1",
    )
    assert _untimed(by_keywords.result.to_dict()) == _untimed(by_params.result.to_dict())
    paper = by_keywords.result.paper
    assert paper is not None and paper.axes == ["x"]
    np.testing.assert_array_equal(by_keywords.corrected, by_params.corrected)


def test_turntable_parameters_by_name_with_units_and_standard_errors():
    rec, truth = spincal.simulate(seed=7)
    fit = spincal.fit_turntable([rec], rpm=33.3, radius_m=0.1)
    params = fit.parameters
    rows = fit.to_dict()["params"]
    assert list(params) == [r["name"] for r in rows]
    radius = params["radius"]
    assert radius.unit == "m" and radius.stderr is not None and radius.stderr > 0
    assert abs(radius.value - truth.turntable.radius_m) < 5 * radius.stderr + 1e-4
    table = params.to_pandas()
    assert table.index.name == "name" and len(table) == len(rows)
    with pytest.raises(KeyError, match="no parameter 'bogus'"):
        params["bogus"]
