"""loadarm's numba caches are stamped with the whole package's sources (loadarm._numba).

Found: numba reused the low-frequency integrator's cached code (ship/motion.py unchanged) after the mooring
kernel it inlines (ship/mooring.py) had been edited and the edit undone; the cached integrator read past the end
of the lines' array and the moored ship drifted tens of metres in calm weather, silently.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import time

import pytest
from numba.core.registry import CPUDispatcher

from loadarm import _numba

MODULES = ["loadarm.ship.mooring", "loadarm.ship.motion", "loadarm.studies.kernel", "loadarm.hydraulics.circuit",
           "loadarm.hydraulics.components", "loadarm.hydraulics.reference"]


def test_the_stamp_follows_every_source_file(tmp_path):
    (tmp_path / "sub").mkdir()
    a, b = tmp_path / "a.py", tmp_path / "sub" / "b.py"
    a.write_text("x = 1\n")
    b.write_text("y = 2\n")
    (tmp_path / "notes.txt").write_text("not a source")
    s0 = _numba.source_stamp(tmp_path)
    assert _numba.source_stamp(tmp_path) == s0
    (tmp_path / "notes.txt").write_text("still not a source, longer")
    assert _numba.source_stamp(tmp_path) == s0
    b.write_text("y = 3\n")                                       # same size, later time
    t = time.time() + 5
    os.utime(b, (t, t))
    s1 = _numba.source_stamp(tmp_path)
    assert s1 != s0
    a.write_text("x = 10\n")                                      # another size
    assert _numba.source_stamp(tmp_path) not in (s0, s1)


@pytest.mark.parametrize("name", MODULES)
def test_every_cached_kernel_is_stamped_with_the_package(name):
    mod = importlib.import_module(name)
    kernels = [v for v in vars(mod).values() if isinstance(v, CPUDispatcher) and v._cache is not None
               and v.py_func.__module__ == name]
    assert kernels, f"{name} has no cached numba function"
    assert _numba.LOCATORS, "numba's cache locators are not where loadarm._numba looks for them"
    for k in kernels:
        impl = getattr(k._cache, "_impl", None)
        assert isinstance(impl.locator, _numba.LOCATORS), (name, k.__name__, type(impl.locator))
        assert impl.locator.get_source_stamp() == _numba.source_stamp(), "a stamp of another version of the sources"


def test_functions_outside_the_package_keep_numba_s_own_stamp(tmp_path):
    f = tmp_path / "elsewhere.py"
    f.write_text("def g(x):\n    return x + 1\n")
    spec = importlib.util.spec_from_file_location("elsewhere", f)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    g = _numba.njit(cache=True)(mod.g)
    assert not isinstance(g._cache._impl.locator, _numba.LOCATORS)
    assert g(1) == 2
