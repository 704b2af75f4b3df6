"""numba's ``njit``, with loadarm's compiled functions cached under a stamp of the whole package's sources.

numba keeps each ``cache=True`` function's machine code beside its source and reuses it while that one file is
unchanged. A function that inlines another from a second file (the low-frequency integrator in
:mod:`loadarm.ship.motion` inlines :mod:`loadarm.ship.mooring`'s restoring force) is then reused after the
second file changed. Found: after an edit to the mooring kernel was undone, the integrator kept the edited
code and read past the end of the lines' array: the ship drifted tens of metres in calm weather, with no error.

Here every loadarm function's cache is stamped with the size and modification time of every source file of
the package (:func:`source_stamp`): any edit anywhere invalidates them all, and the next call compiles again
(about a second per kernel, once). numba's other functions are untouched: the locator below answers only for
files inside this package. Every loadarm module that compiles with numba imports ``njit`` from here.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from numba import njit
from numba.core import caching

__all__ = ["source_stamp", "PACKAGE", "LOCATORS"]  # and numba's njit, for loadarm's modules

#: The package's source folder.
PACKAGE = Path(__file__).resolve().parent


def source_stamp(root: Path = PACKAGE) -> str:
    """A digest of the path, size and modification time of every ``.py`` file under ``root``.

    Parameters
    ----------
    root : Path

    Returns
    -------
    str
        Hex digest.
    """
    h = hashlib.sha256()
    for top, dirs, files in os.walk(root):
        dirs.sort()
        for name in sorted(files):
            if name.endswith(".py"):
                st = os.stat(os.path.join(top, name))
                h.update(f"{os.path.relpath(top, root)}/{name}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def _inside(py_file) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE)
    except (OSError, ValueError):
        return False


def _stamped(base, stamp: str):
    """numba's locator ``base``, answering only for this package's files and stamped with ``stamp`` (the
    sources' stamp when this process imported them: the code it compiles and saves)."""

    class Stamped(base):
        def get_source_stamp(self):
            return stamp

        @classmethod
        def from_function(cls, py_func, py_file):
            return super().from_function(py_func, py_file) if _inside(py_file) else None

    Stamped.__name__ = Stamped.__qualname__ = f"Package{base.__name__.lstrip('_')}"
    return Stamped


def _register() -> tuple:
    """Put the stamped locators first, in numba's own order (a ``NUMBA_CACHE_DIR`` of the user's, the source
    tree, the user-wide cache when the tree is read-only), once. With a numba whose locators are not where
    0.68 keeps them nothing is registered (numba's own stamps then hold, as before)."""
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    bases = [getattr(caching, n, None) or getattr(caching, "_" + n, None)
             for n in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")]
    if impl is None or None in bases:
        return ()
    classes = impl._locator_classes
    if any(getattr(c, "_loadarm", False) for c in classes):
        return tuple(c for c in classes if getattr(c, "_loadarm", False))
    stamp = source_stamp()
    ours = [_stamped(b, stamp) for b in bases]
    for c in ours:
        c._loadarm = True
    classes[0:0] = ours
    return tuple(ours)


LOCATORS = _register()
