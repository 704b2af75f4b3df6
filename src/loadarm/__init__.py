"""loadarm: automatic guidance of marine loading arms.

The package is laid out by role and data flows one way, down the layer table of ``docs/architecture.md``
(``tests/test_architecture.py`` holds the code to it): the vocabulary and base types (:mod:`~loadarm.vocab`,
:mod:`~loadarm.errors`, :mod:`~loadarm.results`, :mod:`~loadarm.files`, :mod:`~loadarm.eventlog`,
:mod:`~loadarm.figures`) -> :mod:`loadarm.arm` -> :mod:`loadarm.params` -> :mod:`loadarm.ship` ->
:mod:`loadarm.design` -> :mod:`loadarm.hydraulics` -> :mod:`loadarm.guidance` -> :mod:`loadarm.sim` ->
:mod:`loadarm.studies` -> :mod:`loadarm.opcua` -> :mod:`loadarm.hmi` -> :mod:`loadarm.testing` ->
:mod:`loadarm.present` -> :mod:`loadarm.cli`.
"""

__version__ = "0.1.0"
