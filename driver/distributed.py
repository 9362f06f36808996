"""Sweeps on Dask (dask.distributed): each run is a task that writes its own run directory; the
client only collects what became of each run.

A local cluster has one worker process per run slot (`--workers N`, one thread each: the
1-rank LAMMPS session runs in the worker's process and changes its directory); `--scheduler
ADDRESS` sends the runs to an existing cluster, whose workers need this package installed
(`pip install brittle-driver` or the checkout with `pip install -e .`) and access to the sweep
directory. A run that fails is recorded with its error and the others go on. Interrupting the
client ends the cluster; a run cut off there is `stale` and a re-run of the sweep resumes it
from its checkpoint (or starts it again when it had none).
"""

from __future__ import annotations

import time
from typing import Any

from rich.console import Console


def run_one(cfg_data: dict[str, Any], np_ranks: int | None) -> dict[str, Any]:
    """One run of a sweep, in a worker: resumed when it was interrupted, else run from the start;
    returns {run_dir, state, error, seconds}."""
    from driver.config import parse_config  # noqa: PLC0415
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.rundir import latest_checkpoint, read_status  # noqa: PLC0415

    cfg = parse_config(cfg_data, f"sweep run {cfg_data.get('name')}")
    run_dir = cfg.run_dir()
    resume = latest_checkpoint(run_dir) is not None or bool((read_status(run_dir) or {}).get("lammps_done"))
    t0 = time.time()
    try:
        execute(cfg, np_ranks=np_ranks, show_progress=False, resume=resume)
    except Exception as exc:  # noqa: BLE001 - the client records it; the other runs go on
        return {"run_dir": str(run_dir), "state": "failed", "error": f"{type(exc).__name__}: {exc}",
                "seconds": time.time() - t0}
    return {"run_dir": str(run_dir), "state": "finished", "error": None, "seconds": time.time() - t0}


def run_on_dask(todo: list[tuple[dict[str, Any], Any]], np_ranks: int | None, workers: int,
                scheduler: str | None, console: Console) -> list[dict[str, Any]]:
    """Run `todo` ((varied values, RunConfig) pairs) on Dask; returns one record per run, in
    the order they ended. Progress: done / running / failed / pending and the ETA."""
    from distributed import Client, LocalCluster, as_completed  # noqa: PLC0415
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn  # noqa: PLC0415

    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    records: list[dict[str, Any]] = []
    try:
        futures = {client.submit(run_one, cfg.model_dump(mode="json"), np_ranks, pure=False,
                                 key=f"run-{cfg.name}"): values for values, cfg in todo}
        slots = workers if not scheduler else max(1, len(client.scheduler_info().get("workers", {})))
        columns = [TextColumn("[bold]sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} done"),
                   TextColumn("{task.fields[running]} running, {task.fields[failed]} failed, "
                              "{task.fields[pending]} pending"), TimeElapsedColumn(), TextColumn("ETA"),
                   TimeRemainingColumn()]
        with Progress(*columns, console=console) as progress:
            task = progress.add_task("sweep", total=len(futures), running=min(slots, len(futures)), failed=0,
                                     pending=max(0, len(futures) - slots))
            for future in as_completed(futures):
                record = future.result()
                record["values"] = futures[future]
                records.append(record)
                if record["state"] == "failed":
                    console.print(f"[red]failed[/] {record['values']}: {record['error']} "
                                  f"(see {record['run_dir']}/status.json)", highlight=False)
                left = len(futures) - len(records)
                progress.update(task, completed=len(records), running=min(slots, left),
                                pending=max(0, left - slots),
                                failed=sum(r["state"] == "failed" for r in records))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return records
