"""Beside a real PLC (issue 14): the guidance controller served over OPC UA, secure by default; the PLC link and its
simulator. See ``docs/plant-integration.md``."""
