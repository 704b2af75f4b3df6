"""The simulated world around the controller: the scripted operator, the simulated arm and its angle sensors, the ERS
valves and their faults, the flange sensor's readings, the closed loop and its :class:`RunResult`."""
