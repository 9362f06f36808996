"""Cluster files (`driver sweep --cluster`, `driver cluster`): the example Slurm configuration
builds a dask-jobqueue SLURMCluster whose job script starts one single-threaded worker per
run slot with the site's prologue. Nothing is submitted: this machine has no batch system."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from driver.cli import app
from driver.config import ConfigError

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "cluster" / "slurm.yaml"


def test_example_slurm_cluster_object_and_job_script():
    pytest.importorskip("dask_jobqueue")
    from driver.cluster import cluster_slots, make_cluster

    cluster, jobs = make_cluster(EXAMPLE)
    try:
        script = cluster.job_script()
        assert type(cluster).__name__ == "SLURMCluster" and jobs == 4
        assert "#SBATCH -A myproject" in script and "#SBATCH -p normal" in script
        assert "#SBATCH --cpus-per-task=32" in script and "#SBATCH -t 04:00:00" in script
        assert "source $HOME/venvs/brittle/bin/activate" in script
        worker = next(line for line in script.splitlines() if "dask_worker" in line)
        assert "--nthreads 1" in worker and "--nworkers 32" in worker
        assert cluster_slots(cluster, jobs) == 128
        assert not cluster.workers  # built, nothing submitted
    finally:
        cluster.close()
    result = CliRunner().invoke(app, ["cluster", str(EXAMPLE)])
    assert result.exit_code == 0 and "#SBATCH -A myproject" in result.output


def test_bad_cluster_files_are_refused(tmp_path):
    pytest.importorskip("dask_jobqueue")
    from driver.cluster import make_cluster, read_cluster_file

    bad = tmp_path / "c.yaml"
    bad.write_text("slurm: {cores: 4}\npbs: {cores: 4}\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: expected exactly one batch system"):
        read_cluster_file(bad)
    bad.write_text("slurm: {cores: 4}\njobs: 0\n")
    with pytest.raises(ConfigError, match="jobs: expected a whole number >= 1"):
        read_cluster_file(bad)
    bad.write_text("slurm: {cores: 4, memory: 4GB, queues: normal}\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: slurm: .*queues"):
        make_cluster(bad)
    result = CliRunner().invoke(app, ["sweep", str(tmp_path / "none.yaml"), "--cluster", str(bad)])
    assert result.exit_code == 2
