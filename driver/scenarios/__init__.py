"""Scenarios: each turns a validated config into a run directory with results."""
