"""Sweeps on Dask (dask.distributed): each run is a task that writes its own run directory; the
client only collects what became of each run.

A local cluster has one worker process per run slot (`--workers N`, by default the cores
divided by the ranks per run; one thread each: the 1-rank LAMMPS session runs in the worker's
process and changes its directory). `--scheduler ADDRESS` sends the runs to an existing
cluster, whose workers need this package installed (`pip install brittle-driver`, or the
checkout with `pip install -e .`) and the sweep directory on a shared file system.

A run that fails is recorded with its error and the others go on. Interrupting the client
(Ctrl-C or SIGTERM) asks every running run to stop at its next chunk boundary, where it
writes a checkpoint, cancels the runs not started, and waits up to STOP_GRACE_S for the
running ones; a re-run of the sweep keeps the finished runs and resumes the interrupted ones
from their checkpoints. A second Ctrl-C closes the cluster at once: runs cut off there are
`stale` and resume from their last periodic checkpoint (or start again when they had none).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import time
import uuid
from typing import Any

from rich.console import Console

#: Seconds between two refreshes of the sweep's progress line.
REFRESH_S = 2.0
#: Seconds the client waits for the running runs to write their checkpoints after a stop.
STOP_GRACE_S = 120.0


def cores() -> int:
    """Cores this process may use (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_workers(np_ranks: int | None) -> int:
    """Runs at a time on this machine: one per core, or cores // ranks per run."""
    return max(1, cores() // max(1, np_ranks or 1))


def longest_first(todo: list[tuple[dict[str, Any], Any]]) -> list[tuple[dict[str, Any], Any]]:
    """`todo` in the order the runs should start: the longest expected first, so that no long
    run is left alone at the end of the sweep while the other workers idle (list scheduling,
    longest processing time first). Expected length: the size estimate's LAMMPS time, then,
    among runs of equal estimate, their unit's `work` (impacts: v_0^2 / G_c)."""
    from driver.estimate import estimate  # noqa: PLC0415
    from driver.registry import unit_of  # noqa: PLC0415

    def key(item: tuple[dict[str, Any], Any]) -> tuple[float, float]:
        cfg = item[1]
        try:
            seconds = estimate(cfg).seconds
        except Exception:  # noqa: BLE001 - no estimate: keep its place among the unknowns
            seconds = 0.0
        return (float(f"{seconds:.2g}"), unit_of(cfg).work(cfg))  # estimates equal to 2 digits count as equal

    return sorted(todo, key=key, reverse=True)


def run_one(cfg_data: dict[str, Any], np_ranks: int | None, token: str) -> dict[str, Any]:
    """One run of a sweep invocation `token`, in a worker: resumed when it was interrupted,
    else run from the start; returns {run_dir, state (finished | failed | interrupted |
    not started), error, seconds}."""
    from driver.config import parse_config  # noqa: PLC0415
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.rundir import can_resume  # noqa: PLC0415
    from driver.runner import RunInterrupted, bind_sweep_token  # noqa: PLC0415

    cfg = parse_config(cfg_data, f"sweep run {cfg_data.get('name')}")
    run_dir = cfg.run_dir()
    if not bind_sweep_token(run_dir, token):  # queued on this worker when the sweep was stopped
        return {"run_dir": str(run_dir), "state": "not started", "error": None, "seconds": 0.0}
    resume = can_resume(run_dir)
    t0 = time.time()
    try:
        execute(cfg, np_ranks=np_ranks, show_progress=False, resume=resume)
    except RunInterrupted as exc:
        return {"run_dir": str(run_dir), "state": "interrupted", "error": str(exc), "seconds": time.time() - t0}
    except Exception as exc:  # noqa: BLE001 - the client records it; the other runs go on
        return {"run_dir": str(run_dir), "state": "failed", "error": f"{type(exc).__name__}: {exc}",
                "seconds": time.time() - t0}
    return {"run_dir": str(run_dir), "state": "finished", "error": None, "seconds": time.time() - t0}


class SweepInterrupted(Exception):
    """The client was interrupted; `records` are the runs that ended (finished, failed or
    stopped with a checkpoint) and `cut` the run dirs that did not answer in time."""

    def __init__(self, records: list[dict[str, Any]], cut: list[str]):
        super().__init__("sweep interrupted")
        self.records, self.cut = records, cut


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM stops the client like Ctrl-C (a batch system's stop, or `kill`)."""
    def handler(_signum, _frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _local_cluster(workers: int):
    """A LocalCluster of `workers` single-threaded worker processes that ignore SIGINT, so a
    terminal's Ctrl-C reaches only the client, which stops the runs cleanly (SIG_IGN is
    inherited through exec, and Python keeps an inherited SIG_IGN for SIGINT)."""
    import dask  # noqa: PLC0415
    from distributed import LocalCluster  # noqa: PLC0415

    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        # Dask's statistical profiler samples the running task's stack every 10 ms and holds the
        # GIL while it does: about 8 % of a BCM run's wall time, for a profile nobody reads here
        # and its MALLOC_TRIM_THRESHOLD_ of 64 KiB (returning freed memory to the system at once,
        # for long-lived workers holding data) costs a run a few % in system calls; the runs
        # here free everything when their LAMMPS instance closes: glibc's own threshold is used
        # worker-saturation 1.0: a worker holds only the run it is running, the others wait at
        # the scheduler and go to whichever worker frees first (Dask's default 1.1 gives a
        # one-thread worker a second run in its own queue, which can end the sweep with one
        # worker idle while another still has a run queued behind its current one)
        with dask.config.set({"distributed.worker.profile.enabled": False,
                              "distributed.scheduler.worker-saturation": 1.0,
                              "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
            return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    finally:
        signal.signal(signal.SIGINT, old)


def run_on_dask(todo: list[tuple[dict[str, Any], Any]], np_ranks: int | None, workers: int,
                scheduler: str | None, console: Console, batch: tuple[Any, int] | None = None) -> list[dict[str, Any]]:
    """Run `todo` ((varied values, RunConfig) pairs) on Dask: a local cluster of `workers`
    processes, the scheduler at `scheduler`, or `batch`, a (dask-jobqueue cluster, number of
    jobs) pair from driver/cluster.py (closed here). Returns one record per run, in the order they ended. Progress: done /
    running / failed / pending and the ETA. Raises SweepInterrupted after Ctrl-C or SIGTERM,
    once the running runs stopped."""
    from distributed import Client, wait  # noqa: PLC0415
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn  # noqa: PLC0415

    cluster = None
    with _sigterm_as_interrupt():
        if scheduler:
            client = Client(scheduler)
        elif batch is not None:
            cluster, jobs = batch
            cluster.scale(jobs=jobs)
            console.print(f"submitted {jobs} batch job(s) of Dask workers; runs start as they do")
            client = Client(cluster)
        else:
            cluster = _local_cluster(workers)
            client = Client(cluster)
        records: list[dict[str, Any]] = []
        futures: dict[Any, Any] = {}
        token = uuid.uuid4().hex
        try:
            ordered = longest_first(todo)
            # priority: Dask starts the highest first; submitted in that order too
            futures = {client.submit(run_one, _task_config(cfg), np_ranks, token, pure=False, priority=len(ordered) - i,
                                     key=f"run-{cfg.run_dir().resolve()}"): (values, cfg)
                       for i, (values, cfg) in enumerate(ordered)}
            columns = [TextColumn("[bold]sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} done"),
                       TextColumn("{task.fields[running]} running, {task.fields[failed]} failed, "
                                  "{task.fields[pending]} pending"), TimeElapsedColumn(), TextColumn("ETA"),
                       TimeRemainingColumn()]
            progress = Progress(*columns, console=console) if console.is_terminal else _LineProgress(console)
            with progress:
                task = progress.add_task("sweep", total=len(futures), running=0, failed=0, pending=len(futures))

                def show() -> None:
                    running = len(_processing(client) & {f.key for f in futures if not f.done()})
                    left = len(futures) - len(records)
                    progress.update(task, completed=len(records), running=running, pending=max(0, left - running),
                                    failed=sum(r["state"] == "failed" for r in records))

                show()
                remaining = set(futures)
                while remaining:  # refreshed every REFRESH_S: the running count changes between ends
                    try:
                        done = wait(list(remaining), timeout=REFRESH_S, return_when="FIRST_COMPLETED").done
                    except TimeoutError:
                        done = set()
                    for future in [f for f in futures if f in done]:  # submission order within a refresh
                        remaining.discard(future)
                        records.append(_record(future, futures[future], console))
                    show()
        except KeyboardInterrupt:
            raise SweepInterrupted(records, _stop(client, futures, token, records, console)) from None
        finally:
            client.close()
            if cluster is not None:
                # a worker that imported LAMMPS's MPI may take a while to exit and is then killed:
                # every result is in by now, so that warning is noise
                logging.getLogger("distributed.nanny").setLevel(logging.ERROR)
                cluster.close()
    return records


class _LineProgress:
    """The sweep's progress where the console is not a terminal (a file, a pipe): a plain line
    each time a run ends, instead of a live bar that only a terminal can redraw. Takes the
    calls run_on_dask makes on rich's Progress."""

    def __init__(self, console: Console):
        self.console, self.total, self.shown = console, 0, -1

    def __enter__(self) -> "_LineProgress":
        return self

    def __exit__(self, *exc) -> None:
        return None

    def add_task(self, description: str, total: int, **fields: Any) -> int:
        self.total = total
        return 0

    def update(self, task: int, completed: int, running: int, pending: int, failed: int) -> None:
        if completed != self.shown:  # a run ended (or the first count): one line
            self.shown = completed
            self.console.print(f"sweep: {completed}/{self.total} done, {running} running, {failed} failed, "
                               f"{pending} pending", highlight=False)


def _task_config(cfg) -> dict[str, Any]:
    """A run's config as a task carries it: its run directory made absolute, since a worker
    (on another node, or started elsewhere) resolves relative paths from its own directory."""
    data = cfg.model_dump(mode="json")
    data["output"]["dir"] = str(cfg.run_dir().resolve())
    return data


def _processing(client) -> set[str]:
    """Keys of the tasks the workers are running now."""
    with contextlib.suppress(Exception):  # the scheduler may already be gone
        return {k for keys in client.processing().values() for k in keys}
    return set()


def _record(future, item: tuple[dict[str, Any], Any], console: Console) -> dict[str, Any]:
    values, cfg = item
    try:
        record = future.result()
    except Exception as exc:  # noqa: BLE001 - a worker lost (killed, out of memory): the run failed
        record = {"run_dir": str(cfg.run_dir()), "state": "failed", "error": f"{type(exc).__name__}: {exc}",
                  "seconds": None}
    record["values"] = values
    if record["state"] == "failed":
        console.print(f"[red]failed[/] {values}: {record['error']} (see {record['run_dir']}/status.json)",
                      highlight=False)
    return record


def _stop(client, futures: dict, token: str, records: list[dict[str, Any]], console: Console) -> list[str]:
    """After Ctrl-C: cancel the runs not started, ask the running ones to stop with a checkpoint
    and wait for them (a second Ctrl-C stops waiting). Returns the run dirs cut off."""
    from distributed import wait  # noqa: PLC0415

    from driver.runner import request_stop_sweep  # noqa: PLC0415

    open_futures = [f for f in futures if not f.done()]
    running = _processing(client)
    waiting = [f for f in open_futures if f.key in running]
    client.cancel([f for f in open_futures if f.key not in running])
    if not waiting:
        return []
    console.print(f"[yellow]stopping: {len(waiting)} running run(s) write a checkpoint and stop "
                  f"(Ctrl-C again to stop at once)")
    try:
        client.run(request_stop_sweep, token)
        wait(waiting, timeout=STOP_GRACE_S)
    except KeyboardInterrupt:
        pass
    except Exception:  # noqa: BLE001 - timeout or a lost worker: those runs are cut
        pass
    cut = []
    for f in waiting:
        if f.done() and f.status == "finished":
            records.append(_record(f, futures[f], console))
        else:
            cut.append(str(futures[f][1].run_dir()))
    return cut
