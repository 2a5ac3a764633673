"""Typed result objects: attributes for the library's fields, ``to_dict()`` for the JSON itself.

Every result is the library's own serialisation (the numbers of results.json), parsed once;
nested objects are results too, lists stay lists.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass
from typing import Any, Dict, Iterator, List, Mapping, Optional, Type, TypeVar

import numpy as np
import numpy.typing as npt


R = TypeVar("R", bound="Result")


def _wrap(value: Any) -> Any:
    if isinstance(value, dict):
        return Result(value)
    if isinstance(value, list):
        return [_wrap(v) for v in value]
    return value


class Result:
    """A result with attribute access to its fields; ``to_dict()`` gives the plain JSON data.

    Example::

        >>> r = Result({"omega_radps": 3.49, "params": [{"name": "r", "value": 0.1}]})
        >>> r.params[0].value
        0.1
        >>> r.to_dict()["omega_radps"]
        3.49
    """

    __slots__ = ("_data",)

    def __init__(self, data: Dict[str, Any]):
        object.__setattr__(self, "_data", data)

    @classmethod
    def _from_json(cls: Type[R], text: str) -> R:
        return cls(json.loads(text))

    def __getattr__(self, name: str) -> Any:
        data = object.__getattribute__(self, "_data")
        try:
            return _wrap(data[name])
        except KeyError:
            raise AttributeError(
                f"{type(self).__name__} has no field {name!r} (fields: {', '.join(data)})"
            ) from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __getitem__(self, key: str) -> Any:
        return _wrap(self._data[key])

    def __contains__(self, key: str) -> bool:
        return key in self._data

    def __dir__(self) -> List[str]:
        return sorted(set(self._data) | {"to_dict", "to_json"})

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Result) and self._data == other._data

    def __repr__(self) -> str:
        fields = ", ".join(self._data)
        return f"{type(self).__name__}({fields})"

    def to_dict(self) -> Dict[str, Any]:
        """The plain data (dicts, lists, numbers, strings), as the library serialises it."""
        return json.loads(json.dumps(self._data))

    def to_json(self, indent: Optional[int] = 2) -> str:
        """The data as JSON text."""
        return json.dumps(self._data, indent=indent)


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: ``name`` (without its unit), ``value``, ``stderr`` (one standard
    error; None where the data do not determine it or it was held fixed) and ``unit`` (``""``
    for a pure number), all as the library reports them.

    Example::

        >>> p = Parameter("bias_x", 0.012, 0.0004, "m/s²")
        >>> f"{p.value} ± {p.stderr} {p.unit}"
        '0.012 ± 0.0004 m/s²'
    """

    name: str
    value: float
    stderr: Optional[float]
    unit: str


_NAME_AND_UNIT = re.compile(r"^(.*?) \((.*)\)$")


def _split_unit(label: str) -> "tuple[str, str]":
    """``"bias_x (m/s²)"`` → ``("bias_x", "m/s²")``; a label without a unit keeps ``""``."""
    match = _NAME_AND_UNIT.match(label)
    return (match.group(1), match.group(2)) if match else (label, "")


class Parameters(Mapping[str, Parameter]):
    """Fitted parameters by name, in the library's order: ``params["bias_x"].value``,
    ``.stderr``, ``.unit``; ``to_pandas()`` gives one row per parameter.

    Example::

        >>> ps = Parameters([Parameter("bias_x", 0.01, 0.001, "m/s²")])
        >>> ps["bias_x"].stderr, list(ps)
        (0.001, ['bias_x'])
    """

    __slots__ = ("_items",)

    def __init__(self, items: "List[Parameter]"):
        self._items: Dict[str, Parameter] = {p.name: p for p in items}

    @classmethod
    def _from_library(cls, rows: List[Dict[str, Any]]) -> "Parameters":
        """From the library's rows: ``{name, value, std_error[, unit]}``; a unit in parentheses
        after the name (``"bias_x (m/s²)"``) moves to ``unit``."""
        items = []
        for row in rows:
            name, unit = (row["name"], row["unit"]) if "unit" in row else _split_unit(row["name"])
            items.append(Parameter(name, row["value"], row.get("std_error"), unit))
        return cls(items)

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._items[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r} (parameters: {', '.join(self._items)})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return f"Parameters({', '.join(self._items)})"

    def to_pandas(self) -> Any:
        """A pandas DataFrame indexed by name with columns ``value``, ``stderr``, ``unit``."""
        import pandas as pd

        frame = pd.DataFrame([asdict(p) for p in self._items.values()], columns=["name", "value", "stderr", "unit"])
        return frame.set_index("name")


class TurntableFit(Result):
    """The turntable model fitted to recordings (``spincal fit``'s JSON).

    Fields: ``params`` (name, value, std_error, unit …), ``recordings`` (per recording: rate,
    geometry, residuals), ``correlation``, ``undetermined``, ``remedy``, ``drift``,
    ``cost_final`` …; ``references`` holds the reference acceleration per recording as (n, 3)
    arrays in m/s² (not part of ``to_dict()``).
    """

    __slots__ = ("references",)

    def __init__(self, data: Dict[str, Any], references: Any = ()):
        super().__init__(data)
        object.__setattr__(self, "references", list(references))

    @property
    def parameters(self) -> Parameters:
        """The fitted parameters by name (``fit.parameters["radius"].value``)."""
        return Parameters._from_library(self._data["params"])


class PaperProtocol(Result):
    """The paper's figures of a calibration of turntable recordings (results.json's ``paper``:
    ``comparison``, ``best_on_validation``, ``turntable``, ``sweep``, ``cross_condition``,
    ``division`` …); ``parameters`` (the turntable fit's parameters by name) and ``to_pandas()``
    (the comparison table). Reported for its figures: what is saved is decided on held-out
    conditions (:class:`CampaignResult`'s ``saved`` and ``verdict``)."""

    @property
    def parameters(self) -> Parameters:
        """The turntable fit's parameters by name (``result.parameters["radius"].stderr``)."""
        return Parameters._from_library(self._data["turntable"]["params"])

    def to_pandas(self) -> Any:
        """The comparison of every corrector and model, one row per ``model``: its ``kind``,
        ``structure`` and the mean fit % and RMSE (m/s²) on training, validation and test data,
        as results.json holds them."""
        import pandas as pd

        rows = []
        for row in self._data["comparison"]:
            flat: Dict[str, Any] = {"model": row["model"], "kind": row.get("kind"), "structure": row.get("structure")}
            for part in ("train", "validation", "test"):
                scores = row.get(part) or {}
                flat[f"{part}_fit_percent"] = scores.get("fit_percent_mean")
                flat[f"{part}_rmse_mps2"] = scores.get("rmse_mps2_mean")
            rows.append(flat)
        return pd.DataFrame(rows).set_index("model")


class CampaignResult(Result):
    """A calibration's results.json, from a campaign or from turntable recordings alone (the
    paper's protocol, run as a campaign of turntable runs): ``joint`` (the sensor model with
    standard errors), ``held_out`` scores, ``candidates``, ``saved``, ``verdict``,
    ``undetermined``; ``parameters`` (the sensor model by name), ``gyro_parameters`` and
    ``paper`` (the paper's figures where its protocol ran)."""

    @property
    def paper(self) -> Optional[PaperProtocol]:
        """The paper protocol's figures (:class:`PaperProtocol`), or None for a campaign file."""
        paper = self._data.get("paper")
        return None if paper is None else PaperProtocol(paper)

    @property
    def parameters(self) -> Parameters:
        """The sensor model (bias, scale error, misalignment, quadratic terms) by name, with
        robust standard errors: ``result.parameters["bias_x"].value``."""
        return Parameters._from_library(self._data["joint"]["sensor_params"])

    @property
    def gyro_parameters(self) -> Optional[Parameters]:
        """The gyroscope's bias and sensitivity by name, or None without a gyro calibration."""
        gyro = self._data.get("gyro")
        return None if not gyro else Parameters._from_library(gyro["params"])


class StaticResult(Result):
    """Static calibration: ``intervals`` (the still intervals used) and ``intervals_from``,
    ``fit`` (the calibration, pose norms, residuals), ``rms_before_mps2``, ``reduced`` (set when
    the poses left the model asked for poorly determined and a smaller one was fitted: the model
    asked for and the parameters it left open), and ``gyro`` (the gyroscope's fit or why it
    failed, when the recording has a gyro)."""


class AllanResult(Result):
    """Allan deviation: ``tau_s`` (m,) and ``adev`` (m, 3) as numpy arrays, ``noise`` (noise
    density, bias instability, random walk per axis), ``to_pandas()`` (the curve, one row per
    averaging time); ``curve`` is the library's data as it is."""

    @property
    def tau_s(self) -> npt.NDArray[np.float64]:
        """Averaging times, s."""
        return np.asarray(self._data["curve"]["tau_s"], dtype=np.float64)

    @property
    def adev(self) -> npt.NDArray[np.float64]:
        """Allan deviation per averaging time and axis, shape (len(tau_s), 3), in the data's unit."""
        return np.asarray(self._data["curve"]["adev"], dtype=np.float64).T

    def to_pandas(self) -> Any:
        """The curve as a DataFrame indexed by ``tau_s`` with columns ``adev_x``, ``adev_y``,
        ``adev_z``."""
        import pandas as pd

        adev = self.adev
        frame = pd.DataFrame({f"adev_{a}": adev[:, k] for k, a in enumerate("xyz")}, index=self.tau_s)
        frame.index.name = "tau_s"
        return frame


class Truth(Result):
    """What a simulation really did (every true value of the sensor and the turntable)."""
