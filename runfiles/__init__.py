"""Files of a run that both the driver and the analysis handle, below both: atomic writes,
the run directory's layout, and the BCM cells file. `analysis/` imports from here and never
from `driver/`; `driver/` imports from both."""
