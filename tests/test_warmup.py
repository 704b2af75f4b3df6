"""``loadarm warmup``: every compiled kernel of the package lands in the cache, so that the test workers, a study's
workers and a real-time start load machine code instead of compiling it (``make test`` runs it first)."""

from __future__ import annotations

import importlib
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core.registry import CPUDispatcher

import loadarm

#: Kernels that no workload of the package calls on their own: they are inlined into the kernels that call them
#: (``inline="always"``) and compiled apart only when a test calls them directly.
_INLINED = "always"


def _kernels() -> set[str]:
    """``module.qualname`` of every cached, not-inlined numba function defined in the package."""
    found = set()
    for info in pkgutil.walk_packages(loadarm.__path__, "loadarm."):
        if ".cli" in info.name or ".testing" in info.name:
            continue
        mod = importlib.import_module(info.name)
        for obj in vars(mod).values():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == info.name:
                cached = type(obj._cache).__name__ != "NullCache"          # njit(cache=True)
                if cached and obj.targetoptions.get("inline") != _INLINED:
                    found.add(f"{info.name.rsplit('.', 1)[1]}.{obj.py_func.__qualname__}")
    return found


@pytest.mark.slow
def test_warmup_compiles_every_kernel_of_the_package_into_the_cache(tmp_path):
    """On an empty cache, the command's workloads reach every cached kernel that is not inlined (the index file
    numba writes per function); a second run finds them all and compiles nothing (it is faster by far)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    cmd = [sys.executable, "-m", "loadarm.cli", "warmup"]
    first = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr
    assert first.stdout.splitlines()[-1].startswith("warm: 4 families in ")
    cached = {p.name.split("-")[0] for p in Path(tmp_path).rglob("*.nbi")}
    missing = _kernels() - cached
    assert not missing, f"no workload of loadarm warmup compiles {sorted(missing)}"
    assert len(_kernels()) >= 40                       # the walk found the kernels (not an empty set passing)
    seconds = lambda r: float(r.stdout.splitlines()[-1].split(" in ")[1].split(" s")[0])  # noqa: E731
    second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert second.returncode == 0, second.stderr
    assert seconds(second) < 0.5 * seconds(first)


def test_the_warmup_families_run_one_per_process_and_name_themselves():
    """Every family has a workload and a place in the order the processes take them (longest first)."""
    from loadarm.cli import warmup

    assert sorted(warmup._ORDER) == sorted(warmup.FAMILIES)
    assert all(callable(f) and f.__doc__ for f in warmup.FAMILIES.values())


@pytest.mark.slow                      # a cold warmup, about 40 s on 2 cores
def test_the_bank_family_compiles_what_the_bank_s_campaign_calls(tmp_path):
    """The bank family calls the clearance and sequence kernels directly on a few samples (a seed of the campaign
    cost 6 s of a warm cache): with the campaign's argument types, so that a seed of the campaign after the warmup
    loads both from the cache and compiles neither (numba's per-signature hit and miss counts)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    warm = subprocess.run([sys.executable, "-m", "loadarm.cli", "warmup"], env=env, capture_output=True, text=True,
                          timeout=600)
    assert warm.returncode == 0, warm.stderr
    probe = ("from loadarm.cli.warmup import _examples\n"
             "from loadarm.arm.clearance import capsule_gaps\n"
             "from loadarm.studies.bank_campaign import bank_sequence, run_bank_campaign\n"
             "run_bank_campaign(_examples() / 'banks' / 'lng150k_bank.toml', "
             "_examples() / 'scenarios' / 'breakout.toml', 1, workers=1)\n"
             "for f in (bank_sequence, capsule_gaps):\n"
             "    print(f.__name__, sum(f.stats.cache_hits.values()), sum(f.stats.cache_misses.values()))\n")
    r = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    counts = {name: (int(h), int(m)) for name, h, m in (line.split() for line in r.stdout.splitlines())}
    assert counts == {"bank_sequence": (1, 0), "capsule_gaps": (1, 0)}, counts
