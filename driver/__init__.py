"""Brittle particle fracture on LAMMPS: config, system builders, runner and CLI."""

__version__ = "0.1.0"
