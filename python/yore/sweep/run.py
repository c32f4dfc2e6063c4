"""Running a sweep on Dask: one task per cell, a local cluster by default, a scheduler address
to scale out; finished cells are written as they come and skipped on ``--resume``.

Local cluster: ``workers`` processes (default: the machine's cores), one thread each, with
OpenMP and BLAS pinned to one thread in every worker (``OMP_NUM_THREADS``,
``OPENBLAS_NUM_THREADS`` and `yore.set_num_threads(1)` in each task), so N workers use N cores
and nothing more. A scheduler address (``tcp://host:8786``) connects to a cluster started with
``dask scheduler`` and ``dask worker tcp://host:8786 --nthreads 1`` (each worker needs yore
installed; the workers need no shared file system: a task gets the scene's text and sends its
results back).

At most a few tasks per worker are in flight at once (`IN_FLIGHT_PER_WORKER`), so the client
holds a bounded number of futures whatever the sweep's size. A lost worker costs the cells it
was running, which Dask runs again elsewhere; a failing cell is recorded, not fatal.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import shutil
import signal
import threading
import time
from pathlib import Path

from ..limits import LIMITS
from ..runtime import SWEEP_WORKER_ENV, deferred_interrupt
from .cell import run_cell
from .results import CELLS_DIR, RESULTS_NAME, Results
from .spec import Sweep, SweepError
from .sweep_file import load_sweep

__all__ = ["run", "resume", "SWEEP_NAME", "SCENE_NAME", "IN_FLIGHT_PER_WORKER"]

SWEEP_NAME = "sweep.toml"
SCENE_NAME = "scene.toml"
META_NAME = "sweep.json"
IN_FLIGHT_PER_WORKER = 4
#: results.nc is rewritten at most this often while cells finish (and at the end).
WRITE_INTERVAL_SECONDS = 5.0
PINNED = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: For the processes the local cluster starts (multiprocessing's resource tracker among them):
#: after a Ctrl-C the tracker frees the semaphores of the workers' processes — its job — and
#: warned about them on stderr ("leaked semaphore objects"), a line the user can do nothing with.
QUIET_TRACKER = "ignore::UserWarning:multiprocessing.resource_tracker"


def _claim(sweep: Sweep, out: Path, resume: bool, overwrite: bool) -> None:
    """Creates ``out`` for this sweep; refuses a folder that holds another sweep (or this one,
    unless resuming or overwriting)."""
    meta = out / META_NAME
    if out.exists() and not out.is_dir():
        raise SweepError(f"{out} is not a folder")
    if meta.is_file() and not resume:
        if not overwrite:
            raise SweepError(
                f"{out} already holds a sweep; `yore sweep --resume {out}` "
                "continues it, --overwrite replaces it"
            )
        for name in (SWEEP_NAME, SCENE_NAME, META_NAME, RESULTS_NAME):
            (out / name).unlink(missing_ok=True)
        shutil.rmtree(out / CELLS_DIR, ignore_errors=True)
    elif not meta.is_file() and out.is_dir() and any(out.iterdir()) and not overwrite:
        raise SweepError(f"{out} is not empty and holds no sweep; choose another -o folder")
    out.mkdir(parents=True, exist_ok=True)
    if not meta.is_file():
        (out / SWEEP_NAME).write_text(sweep.text, encoding="utf-8")
        (out / SCENE_NAME).write_text(sweep.scene_text, encoding="utf-8")
        record = {
            "sweep_path": str(sweep.path.resolve()) if sweep.path else None,
            "scene_path": str(sweep.scene_path) if sweep.scene_path else None,
            "cells": sweep.cell_count,
            "identity": identity(sweep),
        }
        (out / META_NAME).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")


def identity(sweep) -> str:
    """A hash of what the sweep's cells are: the base scene's text, the dimensions (names,
    keys, labels) and every cell's overrides. A resumed sweep must have the one it started
    with."""
    digest = hashlib.sha256()
    digest.update(sweep.scene_text.encode("utf-8"))
    digest.update(
        json.dumps(
            [[d.name, list(d.keys), list(d.labels)] for d in sweep.dimensions], default=str
        ).encode("utf-8")
    )
    for cell in sweep.cells():
        digest.update(
            json.dumps([cell.index, cell.overrides], sort_keys=True, default=str).encode("utf-8")
        )
    return digest.hexdigest()


#: Largest sweep.json read, bytes (it holds two paths, a count and a hash).
MAX_META_BYTES = LIMITS.max_meta_bytes


def _read_meta(out) -> dict:
    """OUT/sweep.json, checked; SweepError naming the file otherwise."""
    path = out / META_NAME
    if not path.is_file():
        raise SweepError(f"{out} holds no sweep to resume (no {META_NAME})")
    try:
        if path.stat().st_size > MAX_META_BYTES:
            raise ValueError(f"more than {MAX_META_BYTES} bytes")
        meta = json.loads(path.read_text(encoding="utf-8"))
    except RecursionError:
        meta = None
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise SweepError(
            f"{path}: not a sweep record ({' '.join(str(error).split())[:120]})"
        ) from None
    if (
        not isinstance(meta, dict)
        or not {"sweep_path", "scene_path", "cells"} <= set(meta)
        or not all(
            meta[k] is None or isinstance(meta[k], str) for k in ("sweep_path", "scene_path")
        )
        or not isinstance(meta.get("identity", ""), str)
    ):
        raise SweepError(
            f"{path}: not a sweep record (expected a table with sweep_path, "
            "scene_path, cells and identity)"
        )
    return meta


#: Seconds a scheduler has to answer (``yore sweep --connect-timeout``).
CONNECT_TIMEOUT_SECONDS = 10.0


def _connect(scheduler, timeout):
    """A Dask client of the scheduler at ``scheduler`` (tcp://HOST:PORT), connected within
    ``timeout`` seconds; SweepError otherwise. The connection runs in a helper thread that is
    abandoned if it does not return in time: whatever answers on the port (an HTTP server, a
    silent one) cannot hang the sweep."""
    if not isinstance(scheduler, str) or not re.fullmatch(r"tcp://[^\s/:]+:\d{1,5}", scheduler):
        raise SweepError(
            f"--scheduler must be a Dask scheduler's address tcp://HOST:PORT, got {scheduler!r}"
        )
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, (int, float))
        or not 0.1 <= timeout <= 3600
    ):
        raise SweepError(f"the connect timeout must be in [0.1, 3600] s, got {timeout!r}")
    from dask.distributed import Client

    outcome = {}

    def connect():
        try:
            outcome["client"] = Client(scheduler, timeout=f"{timeout}s")
        except BaseException as error:  # noqa: BLE001 - reported by the caller, in one line
            outcome["error"] = error

    helper = threading.Thread(target=connect, name="yore-connect", daemon=True)
    helper.start()
    helper.join(timeout + 5.0)
    hint = (
        f"start one with `dask scheduler` and workers with `dask worker {scheduler} --nthreads 1`"
    )
    if helper.is_alive():
        raise SweepError(
            f"the Dask scheduler {scheduler} did not answer within {timeout:g} s "
            f"(is it a Dask scheduler?); {hint}"
        )
    if "error" in outcome:
        error = outcome["error"]
        text = " ".join(str(error).split())[:200] or type(error).__name__
        raise SweepError(f"cannot reach the Dask scheduler {scheduler} ({text}); {hint}")
    return outcome["client"]


def max_local_workers() -> int:
    """Most workers a local cluster may have: twice the cores this process may use."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return 2 * max(1, cores)


def _client(scheduler, workers, quiet):
    from dask.distributed import Client, LocalCluster

    workers = workers or os.cpu_count() or 1
    # Dask sets its workers' environment (and PINNED) in this process's os.environ before it
    # spawns them; the client's own environment is put back afterwards, so a sweep leaves the
    # caller's process as it was (its BLAS and OpenMP settings included)
    saved = dict(os.environ)
    # The worker processes ignore SIGINT (a Ctrl-C at the terminal reaches the whole process
    # group, and only this process should act on it, closing the cluster; workers interrupted
    # mid-task printed tracebacks and one never exited): they start with SWEEP_WORKER_ENV set,
    # and what they import first (the `yore` command's module, or the preload
    # yore.sweep.worker) then ignores it. This process keeps its Ctrl-C: one while the cluster starts is recorded
    # (ignoring it here, as yore once did, lost 13 of 14) and acted on once the cluster is up:
    # it is closed, and the sweep stops as interrupted before any cell runs. Their own logs are
    # silenced below CRITICAL: a cell's failure is its result, not a log line.
    main_thread = threading.current_thread() is threading.main_thread()
    caught = []
    previous = (
        signal.signal(signal.SIGINT, lambda number, frame: caught.append(number))
        if main_thread
        else None
    )
    os.environ["PYTHONWARNINGS"] = ",".join(
        filter(None, [os.environ.get("PYTHONWARNINGS"), QUIET_TRACKER])
    )
    os.environ[SWEEP_WORKER_ENV] = "1"
    cluster = client = None
    try:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
            env={**PINNED, SWEEP_WORKER_ENV: "1"},
            preload=["yore.sweep.worker"],
        )
        client = Client(cluster)
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
        os.environ.clear()
        os.environ.update(saved)
        if caught:
            for part in (client, cluster):
                if part is not None:
                    part.close()
    if caught:
        raise KeyboardInterrupt
    return client, cluster


def _check_workers(workers):
    most = max_local_workers()
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= most
    ):
        raise SweepError(
            f"workers must be an integer in [1, {most}], got {workers!r}: at "
            f"most twice this machine's {most // 2} core(s) (a worker is a "
            "process of about 80 MB running one cell on one core; more only "
            "share the cores)"
        )


def run(
    sweep,
    out,
    scheduler=None,
    workers=None,
    quiet=False,
    overwrite=False,
    resume=False,
    cell_function=None,
    connect_timeout=CONNECT_TIMEOUT_SECONDS,
) -> Results:
    """Runs ``sweep`` (a `Sweep` or a sweep file path) into folder ``out``; returns its
    `Results` (``.dataset()`` is the xarray Dataset also written to OUT/results.nc).

    scheduler : "tcp://host:8786" to use a running Dask cluster; default a local one with
    ``workers`` processes. resume : skip the cells ``out`` already holds. cell_function : what
    runs a cell (default `run_cell`; tests pass stand-ins). Raises SweepError before anything
    runs when the sweep or the folder is wrong."""
    _check_workers(workers)
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    out = Path(os.fspath(out))
    # a remote scheduler is reached before anything is written
    remote = _connect(scheduler, connect_timeout) if scheduler is not None else None
    try:
        _claim(sweep, out, resume, overwrite)
        results = Results(sweep, out)
        done = results.load_finished() if resume else set()
    except BaseException:
        if remote is not None:
            remote.close()
        raise
    pending = (cell for cell in sweep.cells() if cell.index not in done)
    todo = sweep.cell_count - len(done)
    if todo == 0:
        if remote is not None:
            remote.close()
        results.reference_errors()
        results.write()
        return results
    function = cell_function or run_cell
    try:
        client, cluster = (remote, None) if remote is not None else _client(None, workers, quiet)
    except BaseException:  # (a Ctrl-C while the cluster started) the Dataset says none ran
        results.reference_errors()
        results.write()
        raise
    try:
        _run_cells(client, sweep, pending, todo, function, results, quiet)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
        # whatever finished is on disk; the Dataset says so even after a Ctrl-C
        results.reference_errors()
        results.write()
    return results


def _run_cells(client, sweep, pending, todo, function, results, quiet):
    """Submits the pending cells to the cluster, a few per worker at a time, and adds each
    result as it comes (the Dataset written every WRITE_INTERVAL_SECONDS)."""
    from dask.distributed import as_completed
    from tqdm.auto import tqdm

    if not quiet:
        print(
            f"yore sweep: {todo} of {sweep.cell_count} cells to run on "
            f"{len(client.scheduler_info()['workers'])} Dask workers; dashboard "
            f"{client.dashboard_link}",
            flush=True,
        )
    limit = IN_FLIGHT_PER_WORKER * max(1, len(client.scheduler_info()["workers"]))
    running = {}
    queue = as_completed()

    def submit_next():
        # a Ctrl-C waits until the future is whole and tracked (one landing inside Dask's
        # Future() left a half-built object whose __del__ printed a traceback)
        with deferred_interrupt():
            cell = next(pending, None)
            if cell is None:
                return False
            future = client.submit(
                function,
                sweep.scene_text,
                str(sweep.scene_path) if sweep.scene_path else None,
                cell.overrides,
                key=f"yore-cell-{cell.key}-{os.getpid()}",
                pure=False,
            )
            running[future.key] = cell
            queue.add(future)
        return True

    for _ in range(limit):
        if not submit_next():
            break
    last_write = time.monotonic()
    failed = 0
    with tqdm(total=todo, desc="yore sweep", unit="cell", disable=quiet or None, delay=2.0) as bar:
        for future in queue:
            cell = running.pop(future.key)
            result = _result_of(future)
            future.release()
            results.add(cell, result)
            failed += result["status"] != "done"
            bar.update(1)
            bar.set_postfix(not_done=failed, refresh=False)
            submit_next()
            if time.monotonic() - last_write >= WRITE_INTERVAL_SECONDS:
                results.write()
                last_write = time.monotonic()


def _result_of(future):
    """A finished cell's result, or a failed cell's record when the task itself failed."""
    try:
        return future.result()
    except Exception as error:  # noqa: BLE001 - the task itself failed (worker)
        return {
            "status": "failed",
            "message": f"{type(error).__name__}: {error}",
            "values": {},
            "positions": None,
            "faces": None,
        }


def resume(
    out,
    scheduler=None,
    workers=None,
    quiet=False,
    cell_function=None,
    connect_timeout=CONNECT_TIMEOUT_SECONDS,
) -> Results:
    """Continues the sweep in folder ``out``: the cells it does not hold yet."""
    out = Path(os.fspath(out))
    meta = _read_meta(out)
    try:
        text = (out / SWEEP_NAME).read_text(encoding="utf-8")
        scene_text = (out / SCENE_NAME).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise SweepError(
            f"{out}: the sweep's {SWEEP_NAME} or {SCENE_NAME} cannot be read ({error})"
        ) from None
    sweep_path = Path(meta["sweep_path"]) if meta.get("sweep_path") else out / SWEEP_NAME
    sweep = load_sweep(sweep_path, text=text, check_cells=False)
    # the base scene as it was when the sweep started (the file may have changed since)
    sweep.scene_text = scene_text
    # the cells are what they were when the sweep started, or nothing runs (folders from
    # before the identity was recorded are checked record by record only)
    if meta.get("identity") and meta["identity"] != identity(sweep):
        raise SweepError(
            f"{out}: {SWEEP_NAME} or {SCENE_NAME} was changed since the sweep "
            "started (its cells are not the ones recorded); restore them, or "
            "start a new sweep in another folder"
        )
    return run(
        sweep,
        out,
        scheduler=scheduler,
        workers=workers,
        quiet=quiet,
        resume=True,
        cell_function=cell_function,
        connect_timeout=connect_timeout,
    )
