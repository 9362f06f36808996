"""Scenarios: each turns a validated config into a run directory with results.

One unit per (model, scenario) pair, in `driver/scenarios/<model>_<scenario>.py`, each holding
a `UNIT` (driver/scenarios/api.py). UNITS below is the list the registry (driver/registry.py)
reads, lazily, the first time a pair is looked up; nothing here imports a unit, so a unit (or
the API, or the shared sections of driver/scenarios/sections.py) imports without the others.

Adding a scenario: write its unit module and add its name here.
"""

#: The unit modules of driver/scenarios/, in the order the registry lists their pairs (the
#: first unit of a scenario kind also places that kind among the config's `scenario:` kinds).
UNITS = ("bpm_shear", "bcm_impact", "bpm_calibrate", "bcm_calibrate", "bpm_impact", "bcm_crush", "bpm_crush",
         "bcm_compress", "bpm_compress")
