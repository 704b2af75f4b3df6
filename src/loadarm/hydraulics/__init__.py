"""The electro-hydraulic circuit of paper Fig. 11 in closed loop on the arm.

* :mod:`~loadarm.hydraulics.components`: one law per component (pump with
  compensator and relief, 4/3-way proportional valve, cylinder friction and
  end stops, the spool's exact discretisation);
* :mod:`~loadarm.hydraulics.circuit`: the compiled closed loop (PID with
  feed-forward, encoder, both drives, the arm's dynamics) and the same plant as
  a continuous right-hand side;
* :mod:`~loadarm.hydraulics.simulate`: runs a plan through it and reports;
* :mod:`~loadarm.hydraulics.servo`: the stateful servo a guidance run drives
  (:class:`~loadarm.hydraulics.servo.HydraulicArm`);
* :mod:`~loadarm.hydraulics.reference`: the same circuit through ``solve_ivp``,
  the independent route;
* :mod:`~loadarm.hydraulics.plots`: its figures.
"""
