"""Shared fixtures. Run by crates/spincal-py/tests/python.rs (cargo test) against the module of
the same build; SPINCAL_CLI names the `spincal` binary of that build. With
SPINCAL_REQUIRE_PYTHON=1 (CI) a skipped test fails the run: nothing is skipped silently."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REQUIRED = os.environ.get("SPINCAL_REQUIRE_PYTHON") == "1"


def pytest_sessionfinish(session, exitstatus):
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = len(reporter.stats.get("skipped", [])) if reporter else 0
    if REQUIRED and skipped and exitstatus == 0:
        reporter.write_line(f"SPINCAL_REQUIRE_PYTHON=1: {skipped} test(s) skipped, which CI does not allow")
        session.exitstatus = 1


@pytest.fixture(scope="session")
def cli():
    """Runs the `spincal` binary of this build; returns the completed process."""
    path = os.environ.get("SPINCAL_CLI") or shutil.which("spincal")
    if not path or not Path(path).exists():
        pytest.skip("no spincal binary (SPINCAL_CLI unset): run through `cargo test`")

    def run(*args, check=True):
        done = subprocess.run([path, *map(str, args)], capture_output=True, text=True)
        if check and done.returncode != 0:
            raise AssertionError(f"spincal {' '.join(map(str, args))} failed ({done.returncode}):\n{done.stderr}")
        return done

    return run


@pytest.fixture(scope="session")
def simulated(tmp_path_factory):
    """A simulated record-player session written as CSV in m/s² (and its truth)."""
    import spincal

    folder = tmp_path_factory.mktemp("sim")
    rec, truth = spincal.simulate(seed=11)
    path = folder / "rec.csv"
    rec.write_csv(path, unit="mps2")
    return path, rec, truth


@pytest.fixture(scope="session")
def trained(tmp_path_factory, simulated, cli):
    """A network trained by the CLI on the simulated session against its turntable fit's reference
    (`spincal fit --reference-csv`, then `spincal train`): model.json's folder. A calibration of
    turntable recordings alone saves nothing (no held-out condition determines the sensor)."""
    path, _, _ = simulated
    out = tmp_path_factory.mktemp("cli-train")
    cli("fit", path, "--radius", "0.1", "--reference-csv", out / "ref.csv")
    cli("train", "--data", path, "--reference", out / "ref.csv", "--hidden", "4", "--restarts", "1", "-o", out / "model.json")
    return out


@pytest.fixture(scope="session")
def calibrated(tmp_path_factory, simulated, cli):
    """The CLI's calibration of the simulated session (a small network, so it is quick)."""
    path, _, _ = simulated
    out = tmp_path_factory.mktemp("cli-cal")
    cli("calibrate", path, "--radius", "0.1", "--sweep", "none", "--hidden", "4", "--restarts", "1", "--out", out)
    return out
