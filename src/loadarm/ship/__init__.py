"""The moored ship: hull geometry, hydrodynamics (capytaine), moorings and fenders, environmental loads, the compiled
:class:`~loadarm.ship.model.ShipModel`, its motion in time and the flange's motion a scenario drives. See
``docs/ship-motion.md``."""
