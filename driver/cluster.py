"""A Dask cluster of batch jobs (dask-jobqueue) for `driver sweep --cluster FILE`.

A cluster file names the batch system and the arguments of its dask-jobqueue class, plus how
many jobs to start:

    slurm:                 # SLURMCluster(**this): one job = `processes` workers of 1 thread
      cores: 32
      processes: 32
      memory: 120GB
      walltime: "04:00:00"
      queue: normal
      account: myproject
      job_script_prologue: ["source ~/venvs/brittle/bin/activate"]
    jobs: 4                # cluster.scale(jobs=4): 128 runs at a time

Each worker is one process with one thread, so a 1-rank run uses one core; with `--np N`
ranks per run, give `cores: C` and `processes: C / N`. The workers need this package installed
(the prologue activates its environment) and the sweep directory on a shared file system.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from driver.config import ConfigError, load_yaml, read_config_text

#: Batch systems of dask-jobqueue a cluster file may name, and their classes.
SYSTEMS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster", "lsf": "LSFCluster",
           "htcondor": "HTCondorCluster"}


def read_cluster_file(path: Path) -> tuple[str, dict[str, Any], int]:
    """(batch system, keyword arguments of its cluster class, number of jobs) from a cluster
    file; ConfigError naming the file and the allowed keys."""
    source = str(path)
    data = load_yaml(read_config_text(Path(path)), source)
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping: one of {', '.join(SYSTEMS)} and jobs")
    systems = [k for k in data if k in SYSTEMS]
    unknown = [str(k) for k in data if k not in SYSTEMS and k != "jobs"]
    if unknown or len(systems) != 1:
        raise ConfigError(f"{source}: expected exactly one batch system ({', '.join(SYSTEMS)}) and jobs: N"
                          + (f"; unknown key(s) {', '.join(unknown)}" if unknown else ""))
    kwargs = data[systems[0]] or {}
    if not isinstance(kwargs, dict):
        raise ConfigError(f"{source}: {systems[0]}: expected the keyword arguments of dask_jobqueue."
                          f"{SYSTEMS[systems[0]]}")
    jobs = data.get("jobs", 1)
    if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs < 1:
        raise ConfigError(f"{source}: jobs: expected a whole number >= 1 (got {jobs!r})")
    return systems[0], kwargs, jobs


def make_cluster(path: Path):
    """The dask-jobqueue cluster object of a cluster file (no job submitted yet) and its job
    count. ConfigError when dask-jobqueue is missing or rejects an argument."""
    system, kwargs, jobs = read_cluster_file(path)
    try:
        import dask_jobqueue  # noqa: PLC0415
    except ImportError:
        raise ConfigError(f"{path}: needs dask-jobqueue: pip install 'brittle-driver[cluster]' "
                          f"(or pip install dask-jobqueue)") from None
    cls = getattr(dask_jobqueue, SYSTEMS[system])
    try:
        cluster = cls(**{"scheduler_options": {"dashboard_address": ":0"}, **kwargs})
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{path}: {system}: {exc}") from None
    return cluster, jobs


def cluster_slots(cluster, jobs: int) -> int:
    """Workers (runs at a time) the cluster has once its jobs run."""
    per_job = getattr(getattr(cluster, "_dummy_job", None), "worker_processes", None) or 1
    return max(1, int(per_job) * jobs)
