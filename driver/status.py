"""`driver status`: what state runs are in, read without touching them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from driver.rundir import MARKER, has_marker, latest_checkpoint, run_state


def _last_step(run_dir: Path) -> int | None:
    """Step of the last complete progress record (thermo.dat), read from its end."""
    path = run_dir / "thermo.dat"
    try:
        with open(path, "rb") as fh:
            fh.seek(0, 2)
            size = fh.tell()
            fh.seek(max(0, size - 65536))
            lines = fh.read().split(b"\n")[:-1]  # the last piece has no newline: incomplete
    except OSError:
        return None
    for line in reversed(lines):
        if line.strip() and not line.startswith(b"#"):
            try:
                return int(float(line.split()[0]))
            except ValueError:
                continue
    return None


def describe_run(run_dir: Path) -> dict[str, Any]:
    """One run's state (running, interrupted, stale, failed, finished), phase, step reached,
    last heartbeat, checkpoint step and the error or note."""
    st = run_state(run_dir)
    ckpt = latest_checkpoint(run_dir)
    note = st.get("error", "")
    if st["state"] == "stale":
        note = (f"process {st.get('pid')} on {st.get('host')} is gone; "
                + ("driver run DIR --resume continues it" if ckpt else "no checkpoint: a re-run starts again"))
    return {"run": str(run_dir), "state": st["state"], "phase": st.get("phase"), "step": _last_step(run_dir),
            "heartbeat": st.get("heartbeat"), "checkpoint": ckpt["step"] if ckpt else None, "note": note}


def describe_runs(paths: list[Path]) -> list[dict[str, Any]]:
    """Rows for run directories; a folder that is not a run lists the runs below it (a sweep)."""
    rows = []
    for path in paths:
        path = Path(path)
        if has_marker(path, MARKER):
            rows.append(describe_run(path))
        elif path.is_dir():
            rows += [describe_run(m.parent) for m in sorted(path.glob(f"**/{MARKER}"))]
    return rows
