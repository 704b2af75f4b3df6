"""Shared fixtures. Hypothesis runs derandomised so CI is reproducible; the
number of examples is raised with HYPOTHESIS_PROFILE=thorough."""

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from loadarm.compiler import compile_model
from loadarm.config import load_config, paper_installation

settings.register_profile("ci", derandomize=True, deadline=None, max_examples=300,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", deadline=None, max_examples=5000,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

ROOT = Path(__file__).resolve().parents[1]
PAPER_TOML = ROOT / "examples" / "paper.toml"


@pytest.fixture(autouse=True, scope="session")
def _private_hydro_cache(tmp_path_factory):
    """Solved hydrodynamics go to a scratch cache, never the user's ~/.cache (found: a berth case in the hostile
    suite changed the loading condition, `loadarm hydro` solved it and kept it in the home folder)."""
    old = os.environ.get("LOADARM_CACHE")
    os.environ["LOADARM_CACHE"] = str(tmp_path_factory.mktemp("hydro-cache"))
    yield
    if old is None:
        os.environ.pop("LOADARM_CACHE", None)
    else:
        os.environ["LOADARM_CACHE"] = old


@pytest.fixture(scope="session")
def inst():
    return load_config(PAPER_TOML)


@pytest.fixture(scope="session")
def model(inst):
    """The paper's case compiled: what every computation takes."""
    return compile_model(inst)


@pytest.fixture(scope="session")
def arm(model):
    return model.arm


@pytest.fixture(scope="session")
def mount(model):
    return model.mount


@pytest.fixture(scope="session")
def paper():
    return paper_installation()
