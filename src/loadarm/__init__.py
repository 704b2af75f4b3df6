"""loadarm: automatic guidance of marine loading arms.

Stages, one module each, data flowing one way:
:mod:`~loadarm.params.config` (TOML) -> :mod:`~loadarm.arm.geometry` -> :mod:`~loadarm.design.sizing` /
:mod:`~loadarm.arm.envelope` -> :mod:`~loadarm.design.path` -> :mod:`~loadarm.design.timing` ->
:mod:`~loadarm.arm.kinematics` -> :mod:`~loadarm.arm.actuators` -> :mod:`~loadarm.design.trajectory`.
:mod:`~loadarm.present.report` and :mod:`~loadarm.cli` sit on top. ``docs/architecture.md`` is the map.
"""

__version__ = "0.1.0"
