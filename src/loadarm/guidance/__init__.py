"""Live guidance to a moving ship: scenarios, flange motion, sensor and estimator, the guidance
state machine, closed-loop runs. See ``docs/guidance.md``."""
