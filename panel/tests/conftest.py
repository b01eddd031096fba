"""Shared fixtures: the C++ programs of the build (ctest passes their paths as
CIRCTEST_TEST_<NAME>; by hand they default to ./build of the source tree), the panel's modules
on sys.path, a simulated trace."""
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "panel", "circtest"))
sys.path.insert(0, os.path.join(HERE, "fakes"))

BUILD_PATHS = {
    "circgen": "gcode-gen/circgen",
    "circana": "analysis/circana",
    "circcomp": "compensation/circcomp",
    "circtest": "session/circtest",
    "simtrace": "tests/support/circtest-simtrace",
}


def program_path(name):
    path = os.environ.get("CIRCTEST_TEST_" + name.upper()) or os.path.join(
        ROOT, "build", BUILD_PATHS[name])
    if not os.access(path, os.X_OK):
        pytest.fail("%s not built at %s (build it, or set CIRCTEST_TEST_%s)" % (
            name, path, name.upper()))
    return path


@pytest.fixture(autouse=True)
def private_history(tmp_path, monkeypatch):
    """circana's default history database (XDG_DATA_HOME) of the test's own, never the user's."""
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg-data"))


@pytest.fixture
def programs():
    import circtest_logic
    return circtest_logic.Programs({n: program_path(n) for n in circtest_logic.PROGRAMS})


def simulate(path, *options):
    """A trace of the machine simulator (tests/support) with the given injected errors."""
    subprocess.run([program_path("simtrace"), "-o", str(path)] + list(options), check=True,
                   capture_output=True)
    return str(path)


@pytest.fixture
def sim_servo(tmp_path):
    """A copy of configs/sim-servo to apply corrections to."""
    import shutil
    dest = tmp_path / "sim-servo"
    shutil.copytree(os.path.join(ROOT, "configs", "sim-servo"), dest)
    return str(dest / "sim-servo.ini")
