"""A linear-12 map's error bars from Python: each row's predicted standard deviation and
``predicted_better`` against an independent numpy propagation of the map's covariance."""

import json

import numpy as np

import spincal


def _linear_model(path, rng):
    """A three-axis map with a covariance A Aᵀ of its 12 parameters (offsets, then the matrix row
    by row), written as a campaign writes it."""
    matrix = np.eye(3) + rng.uniform(-0.01, 0.01, (3, 3))
    offset = rng.uniform(-0.1, 0.1, 3)
    a = rng.normal(0.0, 3e-3, (12, 12))
    scale = np.diag([1.0] * 3 + [0.1] * 9)  # matrix entries multiply ~10 m/s² readings
    covariance = scale @ a @ a.T @ scale
    model = {
        "format_version": 3,
        "spincal_version": spincal.__version__,
        "corrector": {
            "kind": "linear",
            "axes": ["x", "y", "z"],
            "offset_mps2": offset.tolist(),
            "matrix": matrix.tolist(),
            "training": None,
            "uncertainty": {"covariance": covariance.tolist(), "noise_sd_mps2": [0.02, 0.02, 0.02]},
        },
    }
    path.write_text(json.dumps(model))
    return offset, matrix, covariance


def test_a_linear_maps_error_bars_are_its_covariance_propagated(tmp_path):
    rng = np.random.default_rng(46)
    path = tmp_path / "model.json"
    offset, matrix, covariance = _linear_model(path, rng)
    directions = rng.normal(size=(400, 3))
    readings = 9.80665 * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    readings *= rng.uniform(0.2, 1.5, (400, 1))
    corrected = spincal.load_corrector(path).correct(readings)
    assert corrected.predicted_sd is not None and corrected.predicted_better is not None
    expected = readings @ matrix.T + offset
    np.testing.assert_allclose(corrected.accel, expected, rtol=1e-12, atol=1e-12)
    sd = np.empty_like(readings)
    for k in range(3):
        # ∂f_k/∂offset_k = 1, ∂f_k/∂matrix[k][j] = m_j.
        jac = np.zeros((len(readings), 12))
        jac[:, k] = 1.0
        jac[:, 3 + 3 * k : 6 + 3 * k] = readings
        sd[:, k] = np.sqrt(np.einsum("na,ab,nb->n", jac, covariance, jac))
    np.testing.assert_allclose(corrected.predicted_sd, sd, rtol=1e-10)
    better = np.all((expected - readings) ** 2 > 2.0 * sd**2, axis=1)
    assert np.array_equal(corrected.predicted_better, better)
    # Both outcomes occur, so the flag is tested, not constant.
    assert 0 < better.sum() < len(better), better.sum()
