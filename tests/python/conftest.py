"""Fixtures for the FMU validation tests.

FMUs are found in ``$MBFMU_FMU_DIR`` (default ``<repo>/target/fmu``).  A missing FMU makes
the tests that need it FAIL (pytest.fail), never skip.
"""

from __future__ import annotations

import pytest

import fmu_support as fs


def _load(name: str) -> fs.Model:
    try:
        return fs.Model.get(name)
    except fs.MissingFMU as e:
        pytest.fail(str(e), pytrace=False)


@pytest.fixture(scope="session")
def fmu_dir():
    return fs.fmu_dir()


@pytest.fixture(scope="session")
def msd() -> fs.Model:
    return _load("MassSpringDamper")


@pytest.fixture(scope="session")
def tmc() -> fs.Model:
    return _load("TwoMassChain")


@pytest.fixture(scope="session", params=fs.MODELS)
def model(request) -> fs.Model:
    """Each of the two FMUs in turn."""
    return _load(request.param)


@pytest.fixture(scope="session")
def load_model():
    return _load


@pytest.fixture
def logs():
    """The process-global log recorder, routed to us again for this test."""
    fs.ensure_logger()
    return fs.RECORDER


@pytest.fixture
def run_scene():
    """run_scene(model, start_values, **kw) -> fmpy result (see fmu_support.simulate)."""
    return fs.simulate


@pytest.fixture
def instances():
    """Factory for Instances that are all freed at the end of the test."""
    made: list[fs.Instance] = []

    def make(model: fs.Model, name: str | None = None, **kw) -> fs.Instance:
        inst = model.instance(name, **kw)
        made.append(inst)
        return inst

    yield make
    for inst in made:
        inst.free()
