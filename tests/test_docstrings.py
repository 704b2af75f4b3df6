"""Every public function documents its parameters and returns (numpydoc), as python-control checks."""

import importlib
import inspect

import pytest
from numpydoc.validate import validate


def _all_modules() -> list[str]:
    """Every module of the package (new ones are checked without editing this file); the CLI's commands are
    documented for --help (typer), not numpydoc."""
    import pkgutil

    import loadarm

    names = [m.name.removeprefix("loadarm.") for m in pkgutil.walk_packages(loadarm.__path__, "loadarm.")]
    return sorted(n for n in names if n not in {"cli", "__main__"} and not n.startswith("examples"))


MODULES = _all_modules()
#: Checked numpydoc codes: docstring present, summary, every parameter documented and none invented,
#: a Returns section on functions that return something.
CHECKED = {"GL08", "SS01", "PR01", "PR02", "RT01"}


def _public_functions():
    for m in MODULES:
        mod = importlib.import_module(f"loadarm.{m}")
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if inspect.isfunction(obj) or hasattr(obj, "py_func"):       # plain or numba-compiled
                yield f"loadarm.{m}.{name}"


@pytest.mark.parametrize("qualname", list(_public_functions()))
def test_numpydoc(qualname):
    errors = [(c, msg) for c, msg in validate(qualname)["errors"] if c in CHECKED]
    assert not errors, errors
