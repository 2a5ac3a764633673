"""The module under test is the one this build made; errors, stubs and docs."""

import ast
import inspect
import json
import os
from pathlib import Path

import numpy as np
import pytest

import spincal
from spincal import _spincal

STUBS = Path(spincal.__file__).with_name("_spincal.pyi")


def test_module_is_this_builds():
    expected = os.environ.get("SPINCAL_EXPECT_MODULE")
    if expected is None:
        pytest.skip("not run through cargo test")
    assert Path(_spincal.__file__).resolve() == Path(expected).resolve()


def test_error_hierarchy():
    for name in ["FormatError", "ModelError", "FitError", "UsageError", "OutputError"]:
        cls = getattr(spincal, name)
        assert issubclass(cls, spincal.Error) and issubclass(cls, Exception)
        # Shown and pickled as spincal.X, the name users import.
        assert cls.__module__ == "spincal" and cls.__qualname__ == name
        assert repr(cls("x")) == f"{name}('x')"
    assert not issubclass(spincal.FormatError, spincal.ModelError)
    from spincal import FormatError  # noqa: F401  importable by name


def test_errors_carry_their_place_as_attributes(tmp_path):
    import pickle

    path = tmp_path / "bad.csv"
    path.write_text("t,ax,ay,az\n0,1,2,3\n0.01,1,zwei,3\n")
    with pytest.raises(spincal.FormatError) as caught:
        spincal.read(path)
    e = caught.value
    assert (e.path, e.line, e.column, e.column_name) == (str(path), 3, 3, "ay")
    # Attributes survive pickling (Ray ships exceptions between processes).
    again = pickle.loads(pickle.dumps(e))
    assert type(again) is spincal.FormatError and again.line == 3 and str(again) == str(e)
    # A campaign file's key and line.
    campaign = tmp_path / "campaign.toml"
    campaign.write_text('unit = "u"\n[[recording]]\nfile = "missing.csv"\nkind = "static"\n')
    with pytest.raises(spincal.FormatError) as caught:
        spincal.calibrate_campaign(campaign)
    assert (caught.value.path, caught.value.line, caught.value.key) == (str(campaign), 2, "file"), str(caught.value)
    # A model file's field.
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"format_version": 999, "corrector": {"kind": "linear"}}))
    with pytest.raises(spincal.ModelError) as model_error:
        spincal.load_corrector(model)
    assert model_error.value.path == str(model)
    # Where nothing is known, None.
    with pytest.raises(spincal.UsageError) as usage_error:
        spincal.simulate(turntable={"bogus": 1})
    assert usage_error.value.path is None and usage_error.value.line is None


def test_format_error_names_file_line_and_column(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,ax,ay,az\n0,1,2,3\n0.01,1,zwei,3\n")
    with pytest.raises(spincal.FormatError) as caught:
        spincal.read(path)
    text = str(caught.value)
    assert "bad.csv" in text and ":3" in text and "zwei" in text
    with pytest.raises(spincal.Error):
        spincal.read(b"a,b\n1,2\n", name="x.csv")
    with pytest.raises(spincal.FormatError, match="backwards") as caught:
        spincal.recording(np.array([0.0, 0.2, 0.1]), np.zeros((3, 3)))
    assert caught.value.row == 2


def test_model_error_names_the_field(tmp_path):
    path = tmp_path / "model.json"
    path.write_text(json.dumps({"format_version": 999, "corrector": {"kind": "linear"}}))
    with pytest.raises(spincal.ModelError, match="format_version|999"):
        spincal.load_corrector(path)


def test_usage_and_fit_errors():
    with pytest.raises(spincal.UsageError, match="bogus"):
        spincal.simulate(turntable={"bogus": 1})
    with pytest.raises(spincal.UsageError, match="sweep"):
        spincal.calibrate([spincal.simulate()[0]], sweep="huge")
    still = spincal.recording(np.arange(2000) / 100.0, np.tile([0.0, 0.0, 9.81], (2000, 1)))
    with pytest.raises(spincal.FitError, match="rotation"):
        spincal.fit_turntable([still])


def test_output_error_keeps_inputs(tmp_path, simulated):
    _, rec, _ = simulated
    with pytest.raises(spincal.OutputError):
        rec.write_csv(tmp_path / "no-such-folder" / "x.csv")


def _stub_tree():
    return ast.parse(STUBS.read_text())


def _public(obj):
    return {n for n in dir(obj) if not n.startswith("_")}


def test_stubs_name_every_function_class_and_constant():
    tree = _stub_tree()
    stubbed = {node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))}
    stubbed |= {
        node.target.id
        for node in tree.body
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and not node.target.id.startswith("_")
    }
    assert stubbed == _public(_spincal)


def _stub_params(fn: ast.FunctionDef):
    a = fn.args
    names = [p.arg for p in a.posonlyargs + a.args if p.arg != "self"]
    return names, [p.arg for p in a.kwonlyargs]


def _runtime_params(obj):
    sig = inspect.signature(obj)
    positional = [
        p.name
        for p in sig.parameters.values()
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name not in ("self", "$self")
    ]
    keyword = [p.name for p in sig.parameters.values() if p.kind == p.KEYWORD_ONLY]
    return positional, keyword


def test_stub_signatures_match_the_module():
    checked = 0
    for node in _stub_tree().body:
        if isinstance(node, ast.FunctionDef):
            assert _stub_params(node) == _runtime_params(getattr(_spincal, node.name)), node.name
            checked += 1
        elif isinstance(node, ast.ClassDef):
            cls = getattr(_spincal, node.name)
            members = {n.name for n in node.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("__")}
            if not issubclass(cls, BaseException):
                assert members == _public(cls), node.name
            for fn in node.body:
                if isinstance(fn, ast.FunctionDef) and not fn.name.startswith("__"):
                    attr = getattr(cls, fn.name)
                    if callable(attr) and not isinstance(inspect.getattr_static(cls, fn.name), property):
                        try:
                            runtime = _runtime_params(attr)
                        except (ValueError, TypeError):
                            continue
                        assert _stub_params(fn) == runtime, f"{node.name}.{fn.name}"
                        checked += 1
    assert checked >= 20


def test_every_public_function_documents_an_example():
    for name in spincal.__all__:
        obj = getattr(spincal, name)
        if inspect.isfunction(obj):
            doc = inspect.getdoc(obj) or ""
            assert "Example" in doc and ">>>" in doc, name
    text = spincal.calibrate.__doc__ or ""
    assert "spincal calibrate" in text and "progress=True" in text
    assert inspect.signature(spincal.calibrate).parameters["radius_m"].default is None


def test_recording_keeps_the_temperature_column(tmp_path):
    path = tmp_path / "warm.csv"
    path.write_text("t,ax,ay,az,temp_k\n0,0,0,9.8,300\n0.01,0,0,9.8,301\n0.02,0,0,9.8,301\n")
    rec = spincal.read(path)
    assert rec.temperature is not None
    np.testing.assert_allclose(rec.temperature, [26.85, 27.85, 27.85])
    assert rec.columns[-1] == "temp_k"
    path.write_text("t,ax,ay,az\n0,0,0,9.8\n0.01,0,0,9.8\n")
    assert spincal.read(path).temperature is None
