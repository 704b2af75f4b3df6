"""The arm as mathematics: geometry, kinematics (with the 3D Jacobian), actuators, dynamics, the envelope and its
alarm zones, the faces and the alarm sequence, and the compiled :class:`~loadarm.arm.model.ArmModel`.

Imports only the base layer (``errors``, ``vocab``, ``results``, ``_numba``). See ``docs/architecture.md``."""
