"""Preloaded by the local cluster's workers as they start (``LocalCluster(preload=...)``): the modules the
operability tasks run, imported while the client still compiles the ship and the design-drift table (found: the
workers imported them only when the compiled ship first arrived, 1.2 s of every study's start on this machine).
Importing it has no other effect."""

import pandas  # noqa: F401
import pyarrow.parquet  # noqa: F401

from loadarm.ship import model, motion  # noqa: F401
from loadarm.studies import bank_operability, kernel, operability  # noqa: F401
