"""Typed result objects: attributes for the library's fields, ``to_dict()`` for the JSON itself.

Every result is the library's own serialisation (the numbers of results.json), parsed once;
nested objects are results too, lists stay lists.
"""

from __future__ import annotations

import json
from typing import Any, Dict, List, Optional


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
    def _from_json(cls, text: str) -> "Result":
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


class CalibrationResult(Result):
    """Every number of a calibration: the content of results.json (``comparison``, ``chosen``,
    ``turntable``, ``sweep``, ``cross_condition``, ``division`` …)."""


class CampaignResult(Result):
    """A campaign calibration's results.json: ``joint`` (the sensor model with standard errors),
    ``held_out`` scores, ``candidates``, ``saved``, ``verdict``, ``undetermined``."""


class StaticResult(Result):
    """Static calibration: ``intervals`` (the still intervals used) and ``fit`` (the calibration,
    pose norms, residuals)."""


class AllanResult(Result):
    """Allan deviation: ``curve`` (tau_s, adev per axis) and ``noise`` (noise density, bias
    instability, random walk per axis)."""


class Truth(Result):
    """What a simulation really did (every true value of the sensor and the turntable)."""
