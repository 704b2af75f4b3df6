"""Live guidance: the controller and what it decides with, nothing of the world it runs in. Its modes and state
(``modes``), the flange estimator (``estimator``), the joint-angle voter (``voting``), the drift fit (``drift``), the
connected-mode monitor (``monitor``), the safety rules (``rules``) and the state machine (``controller``). The
simulated world it runs against is :mod:`loadarm.sim`; see ``docs/guidance.md``."""
