"""Design before the arm moves: path, timing laws, trajectory, actuator loads, sizing, balancing, the design check,
alarm design, the multibody verification and the surge check. See ``docs/architecture.md``."""
