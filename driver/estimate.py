"""The size estimate of a config before anything is built, through its unit and the size model
of driver/size_model.py, and the check that refuses a run needing more memory than the machine
has (`driver run`, `driver validate`; sweeps order their runs by it)."""

from __future__ import annotations

from pathlib import Path

from driver.config import ConfigError, RunConfig
from driver.registry import unit_of
from driver.size_model import GIB, SizeEstimate


def estimate(cfg: RunConfig, np_ranks: int | None = None) -> SizeEstimate:
    """Size, memory and time of the run `cfg` describes, without building it.

    np_ranks: MPI ranks (`--np`); default cfg.execution.np.
    """
    ranks = np_ranks if np_ranks is not None else cfg.execution.np
    return unit_of(cfg).estimate(cfg, ranks)


def available_memory_bytes(meminfo: str | Path = "/proc/meminfo",
                           cgroup: str | Path = "/sys/fs/cgroup") -> int | None:
    """MemAvailable of /proc/meminfo in bytes, lowered to what the cgroup (v2) memory limit
    leaves (memory.max - memory.current; a container is killed there, whatever the host has).
    None where MemAvailable cannot be read (not Linux)."""
    try:
        text = Path(meminfo).read_text()
    except OSError:
        return None
    available = None
    for line in text.splitlines():
        if line.startswith("MemAvailable:"):
            fields = line.split()
            try:
                available = int(fields[1]) * (1024 if fields[-1].lower() == "kb" else 1)
            except (IndexError, ValueError):
                return None
    if available is None:
        return None
    try:
        limit = Path(cgroup, "memory.max").read_text().strip()
        used = int(Path(cgroup, "memory.current").read_text())
        if limit != "max":
            available = min(available, max(int(limit) - used, 0))
    except (OSError, ValueError):
        pass
    return available


def check_size(cfg: RunConfig, allow_large: bool = False, np_ranks: int | None = None,
               available: int | None = None, source: str | None = None) -> SizeEstimate:
    """The estimate of `cfg`; ConfigError when it needs more memory than is available, unless
    allow_large (`--yes`). available: bytes, default available_memory_bytes() (no check where
    that is unknown). source: the input file, named in the message."""
    est = estimate(cfg, np_ranks)
    if available is None:
        available = available_memory_bytes()
    if available is not None and est.memory_bytes > available and not allow_large:
        where = f"{source}: " if source else ""
        raise ConfigError(f"{where}this run needs about {est.memory_bytes / GIB:.3g} GiB, "
                          f"{available / GIB:.3g} GiB available; use --yes to run anyway\n  {est.describe()}")
    return est
