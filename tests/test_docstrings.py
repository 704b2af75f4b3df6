"""Every public function documents its parameters and returns (numpydoc), as python-control checks."""

import importlib
import inspect

import pytest
from numpydoc.validate import validate

MODULES = ["config", "geometry", "kinematics", "envelope", "sizing", "path", "timing", "actuators", "trajectory",
           "dynamics", "balancing", "loads", "multibody", "slew", "eventlog", "plotting", "report",
           "hydraulics.components", "hydraulics.plant", "hydraulics.simulate", "hydraulics.reference",
           "hydraulics.servo", "guidance.scenario", "guidance.ship", "guidance.sensor", "guidance.controller",
           "guidance.run"]
#: Checked numpydoc codes: docstring present, summary, every parameter documented and none invented,
#: a Returns section on functions that return something.
CHECKED = {"GL08", "SS01", "PR01", "PR02", "RT01"}


def _public_functions():
    for m in MODULES:
        mod = importlib.import_module(f"loadarm.{m}")
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isfunction(obj) or hasattr(obj, "py_func"):       # plain or numba-compiled
                yield f"loadarm.{m}.{name}"


@pytest.mark.parametrize("qualname", list(_public_functions()))
def test_numpydoc(qualname):
    errors = [(c, msg) for c, msg in validate(qualname)["errors"] if c in CHECKED]
    assert not errors, errors
