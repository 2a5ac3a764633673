# Type stubs of the extension module (crates/spincal-py/src/lib.rs); tests/python/test_stubs.py
# checks that every name and parameter here matches the built module.
from os import PathLike
from typing import Any, Callable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Progress = Optional[Callable[[str, int, Optional[int]], Any]]
_Path = Union[str, PathLike[str]]

class Error(Exception): ...
class FormatError(Error): ...
class ModelError(Error): ...
class FitError(Error): ...
class UsageError(Error): ...
class OutputError(Error): ...

class Recording:
    @property
    def time(self) -> npt.NDArray[np.float64]: ...
    @property
    def accel(self) -> npt.NDArray[np.float64]: ...
    @property
    def gyro(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def name(self) -> str: ...
    @property
    def format(self) -> str: ...
    @property
    def columns(self) -> List[str]: ...
    @property
    def metadata(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]: ...
    @property
    def raw_counts(self) -> bool: ...
    @property
    def sample_rate_hz(self) -> float: ...
    @property
    def duration_s(self) -> float: ...
    def __len__(self) -> int: ...
    def write_csv(self, path: _Path, unit: str = "g") -> None: ...

class Corrector:
    @staticmethod
    def load(path: _Path) -> Corrector: ...
    @staticmethod
    def from_json(text: str, name: str = "<model>") -> Corrector: ...
    def to_json(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    @property
    def kind(self) -> str: ...
    @property
    def axes(self) -> List[str]: ...
    @property
    def warmup_samples(self) -> int: ...
    def correct(
        self, accel: npt.NDArray[np.float64]
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_], npt.NDArray[np.bool_]]: ...
    def static_json(self) -> Optional[str]: ...

class Calibration:
    def result_json(self) -> str: ...
    def corrector(self) -> Corrector: ...
    def references(self) -> List[npt.NDArray[np.float64]]: ...
    def corrected(self) -> npt.NDArray[np.float64]: ...
    def write(self, folder: _Path) -> None: ...

class CampaignCalibration:
    def result_json(self) -> str: ...
    def corrector(self) -> Optional[Corrector]: ...
    def write(self, folder: _Path) -> None: ...

def read(
    source: Union[_Path, bytes],
    *,
    name: Optional[str] = None,
    format: Optional[str] = None,
    columns: Optional[str] = None,
    accel_unit: Optional[str] = None,
    time_unit: Optional[str] = None,
    gyro_unit: Optional[str] = None,
    sample_rate_hz: Optional[float] = None,
    accel_scale: Optional[float] = None,
    retime: bool = False,
) -> Recording: ...
def recording(
    time: npt.NDArray[np.float64],
    accel: npt.NDArray[np.float64],
    gyro: Optional[npt.NDArray[np.float64]] = None,
    *,
    name: str = "array",
) -> Recording: ...
def simulate(
    sensor_json: Optional[str] = None, turntable_json: Optional[str] = None, seed: int = 7
) -> Tuple[Recording, str]: ...
def simulation_defaults() -> Tuple[str, str, str]: ...
def simulate_campaign(folder: _Path, seed: int = 7, setup_json: Optional[str] = None) -> str: ...
def fit_turntable(
    recordings: Sequence[Recording],
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: float = 0.002,
    objective_axes: str = "xyz",
    drift: bool = True,
    fit_offsets: bool = True,
    separate_radii: bool = False,
    gravity_mps2: float = ...,
    range_g: Optional[float] = None,
    bounds: Sequence[Tuple[str, float, float]] = ...,
    progress: _Progress = None,
) -> Tuple[str, List[npt.NDArray[np.float64]]]: ...
def calibrate(
    recordings: Sequence[Recording],
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: float = 0.002,
    objective_axes: str = "xyz",
    drift: bool = True,
    fit_offsets: bool = True,
    separate_radii: bool = False,
    gravity_mps2: float = ...,
    range_g: Optional[float] = None,
    sweep: Optional[str] = None,
    hidden: Optional[str] = None,
    restarts: int = 3,
    sweep_hessian_samples: int = ...,
    correct_axes: str = "x,y",
    delays: int = 0,
    seed: int = 1,
    arx: str = "6,8,1",
    bj: str = "4,4,4,4,1",
    narx: str = "2,2,1",
    hw: str = "2,3,1",
    progress: _Progress = None,
) -> Calibration: ...
def calibrate_campaign(campaign: _Path, *, progress: _Progress = None) -> CampaignCalibration: ...
def static_calibration(
    recording: Recording,
    *,
    parameters: int = 9,
    gravity_mps2: float = ...,
    init_s: float = 2.0,
    window_s: float = 1.0,
    threshold_factor: float = 3.0,
    min_interval_s: float = 2.0,
) -> Tuple[str, Corrector]: ...
def allan(accel: npt.NDArray[np.float64], dt_s: float, *, per_decade: int = 10) -> str: ...
def sensitivity(
    *,
    radius_m: float = 0.1,
    tilt_deg: float = 5.0,
    rpm: float = 33.3,
    beta_deg: float = 0.0,
    gravity_mps2: float = ...,
    vary_percent: float = 15.0,
) -> str: ...
def version() -> str: ...
