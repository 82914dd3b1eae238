"""Where runs are processed: on this machine (a few runs in flight) or on Dask workers; the progress bar."""

from __future__ import annotations

import logging
import sys
import time
import uuid
from pathlib import Path
from typing import Any, Callable, Iterable

from roadtex._checks import usable_cores
from roadtex.archive.plan import JobPlan
from roadtex.errors import MissingDependencyError

log = logging.getLogger("roadtex.archive")

#: What an engine runs for each run: :func:`roadtex.archive.worker.process_run` (passed in, so that
#: the engines stay below the job that uses them).
RunWorker = Callable[..., dict[str, Any]]


#: Runs in flight on the local engine when the job is given its ``threads``: two, so that one run's
#: reading, conditioning, spectra and writing (Python, one core) overlap the other's contact solve
#: (Rust, ``threads`` cores, GIL released). Memory holds at most this many runs.
LOCAL_RUNS_IN_FLIGHT = 2

#: Most runs in flight when the job chooses its threads (``threads=None``, see :func:`local_schedule`):
#: memory holds at most this many runs (a line run's model grid is chunked to 2^22 points, 256 MB
#: of envelopes and pressures for four moduli, whatever its length).
MAX_LOCAL_RUNS_IN_FLIGHT = 5


def local_schedule(threads: int | None, cores: int | None = None) -> int:
    """Runs in flight on the local engine on ``cores`` (default: the cores this process may use):
    :data:`LOCAL_RUNS_IN_FLIGHT` when the job is given its ``threads``; left to the job (None), one
    more than the cores, at most :data:`MAX_LOCAL_RUNS_IN_FLIGHT` (each run's solves on
    :func:`run_threads`). A run in its Python steps (reading, conditioning, spectra, writing) holds
    the GIL, one core's worth, while the others keep every core solving.

    Measured on 2 cores (issue 39, 2026-12-02, ``benches/local_schedule.py``: this schedule and two
    runs on both cores alternated in one process, the line pilots kept from a first job, the same
    tables bit for bit): 1 km at 0.5 mm, the default job 12.0 to 12.3 s against 13.2 to 13.6 s, its
    data grid 5.3 to 5.7 s against 6.3 to 6.5 s; 1 km at 1 mm 8.1 s against 9.1 to 9.4 s, 3.9 to 4.3 s
    against 4.4 to 4.6 s; the demo's archive (three 1 mm surfaces, their pilots included) 25.6 and
    25.8 s against 27.1 and 28.5 s. Four runs on one thread each did no better than three.
    """
    if threads is not None:
        return LOCAL_RUNS_IN_FLIGHT
    cores = max(1, usable_cores() if cores is None else cores)
    return min(cores + 1, MAX_LOCAL_RUNS_IN_FLIGHT)


def run_threads(threads: int | None, remaining: int, cores: int | None = None) -> int:
    """Rust threads for the solves of the next run the local engine starts, ``remaining`` runs (this
    one included) still to start: ``threads`` when given; left to the job (None), the cores shared by
    the runs that can solve at once (:func:`local_schedule` less the one in Python), so one thread
    each in a long job, and the last runs (or a job of one run) every core."""
    if threads is not None:
        return threads
    cores = max(1, usable_cores() if cores is None else cores)
    solving = max(1, min(local_schedule(None, cores) - 1, remaining))
    return max(1, cores // solving)


def process_local(work: RunWorker, runs: list[dict[str, Any]], sizes: list[int], plan: JobPlan, out: Path,
                   threads: int | None, flags: dict[str, Any]) -> Iterable[tuple[dict[str, Any], int]]:
    """Runs in manifest order, a bounded number at a time (:func:`local_schedule`); yields (status,
    size) as each finishes."""
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    cores = usable_cores()   # once a job: the schedule and every run's threads are of the same cores
    in_flight_limit = local_schedule(threads, cores)
    pending = list(zip(runs, sizes))[::-1]
    with ThreadPoolExecutor(max_workers=in_flight_limit, thread_name_prefix="roadtex-run") as pool:
        in_flight: dict[Any, int] = {}
        try:
            while pending or in_flight:
                while pending and len(in_flight) < in_flight_limit:
                    solve_threads = run_threads(threads, len(pending), cores)
                    run, size = pending.pop()
                    in_flight[pool.submit(work, run, plan, out, threads=solve_threads, **flags)] = size
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                for future in done:
                    size = in_flight.pop(future)
                    yield future.result(), size
        finally:
            for future in in_flight:
                future.cancel()


def process_dask(work: RunWorker, runs: list[dict[str, Any]], sizes: list[int], plan: JobPlan, out: Path,
                  scheduler: str | None, workers: int, threads: int | None,
                  flags: dict[str, Any]) -> Iterable[tuple[dict[str, Any], int]]:
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise MissingDependencyError("engine='dask' needs dask.distributed: pip install 'roadtex[dask]'") from None
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        threads = 1 if threads is None else threads
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        by_key = {}
        futures = []
        for run, size in zip(runs, sizes):
            # the plan travels to the workers with each run: what the job decided, not the options' hidden fields
            future = client.submit(work, run, plan, str(out), threads=threads, **flags,
                                   key=f"roadtex-run-{run['run_id']}-{uuid.uuid4().hex[:8]}", pure=False)
            by_key[future.key] = size
            futures.append(future)
        for future in as_completed(futures):
            yield future.result(), by_key[future.key]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class Progress:
    """A progress bar counting runs, with the kilometres of profile done and an ETA.

    The ETA weighs what is left by file size (runs differ in length): remaining time = elapsed x
    (bytes left / bytes done). Skipped runs (already done) do not count towards the rate.
    """

    def __init__(self, runs: int, total_bytes: int, quiet: bool):
        self.runs, self.done, self.km, self.quiet = runs, 0, 0.0, quiet
        self.total_bytes, self.bytes_done, self.work_bytes = max(total_bytes, 1), 0, 0
        self.started = time.perf_counter()
        self.bar = None
        if not quiet:
            from tqdm import tqdm

            self.bar = tqdm(total=runs, unit="run", file=sys.stderr, dynamic_ncols=True,
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} runs{postfix}")

    def eta(self) -> str:
        elapsed = time.perf_counter() - self.started
        if self.work_bytes == 0:
            return "ETA ?"
        left = elapsed * (self.total_bytes - self.bytes_done) / self.work_bytes
        return f"ETA {int(left // 60)}:{int(left % 60):02d}"

    def update(self, status: dict[str, Any], size: int) -> None:
        self.done += 1
        self.bytes_done += size
        state = "skipped" if status.get("skipped") else status["state"]
        if state != "skipped":
            self.work_bytes += size
            self.km += float(status.get("kilometres", 0.0))
        elapsed = time.perf_counter() - self.started
        if self.bar is not None:
            rate = self.km / elapsed * 3600 if elapsed > 0 else 0.0
            self.bar.set_postfix_str(f"{self.km:.3f} km, {rate:.2f} km/h, {self.eta()}", refresh=False)
            self.bar.update(1)
        else:
            detail = f": {status.get('stage')}: {status.get('message')}" if state == "error" else ""
            log.info("run %d/%d %s %s (%.3f km so far, %s)%s", self.done, self.runs, status["run_id"], state, self.km,
                     self.eta(), detail)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
