"""loadarm: automatic guidance of marine loading arms.

Stages, one module each, data flowing one way:
:mod:`~loadarm.config` (TOML) -> :mod:`~loadarm.geometry` -> :mod:`~loadarm.sizing` /
:mod:`~loadarm.envelope` -> :mod:`~loadarm.path` -> :mod:`~loadarm.timing` ->
:mod:`~loadarm.kinematics` -> :mod:`~loadarm.actuators` -> :mod:`~loadarm.trajectory`.
:mod:`~loadarm.plotting`, :mod:`~loadarm.report` and :mod:`~loadarm.cli` sit on top.
"""

__version__ = "0.1.0"
