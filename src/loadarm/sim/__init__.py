"""The simulated world around the controller and the closed loop: the scripted operator, the simulated arm, its
angle sensors and the ERS valves with their faults (``world``), the flange sensor's readings (``sensors``), the run
compiled once (``spec``: :class:`~loadarm.sim.spec.RunSpec`), the closed loop (``loop``), its verdict (``result``:
:class:`~loadarm.sim.result.RunResult`), one cycle's state for the screen and its replay (``snapshot``), the
overstretch look-ahead and the clearance watch (``limits``) and the run's figures (``plots``)."""
