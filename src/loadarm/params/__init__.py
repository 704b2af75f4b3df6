"""Files at the edge: parameter declarations, the installation, the berth and the scenario, parsed into typed records
and compiled once into the arm model and the run specification. See ``docs/architecture.md``."""
