"""The local engine's schedule: how many runs are in flight and on how many threads each solves.

The results do not depend on it (test_determinism.py: the same tables bit for bit whatever the
threads); what is checked here is that the cores are shared as documented: a long job keeps one
run more in flight than the cores, each solving on one thread, a job's last run (or its only one)
gets every core, and threads given by the user are used as given.
"""

from __future__ import annotations

import concurrent.futures
import threading
from pathlib import Path
from typing import Any

import pytest

import roadtex.archive.engines as engines
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.plan import JobPlan


def run_fake_job(monkeypatch: pytest.MonkeyPatch, cores: int, runs: int, threads: int | None,
                 together: int = 1) -> tuple[int, list[int]]:
    """process_local over ``runs`` runs whose work only records the threads it was given, on a
    machine of ``cores``: (most runs in flight at once, threads per run in manifest order).

    In flight counts the runs submitted and not yet yielded back (the engine's own bookkeeping,
    counted, not timed). The first ``together`` runs also wait for each other (a barrier, not a
    sleep): a pool that cannot run that many at once never lets them through, and the test fails on
    the barrier's timeout."""
    monkeypatch.setattr(engines, "usable_cores", lambda: cores)
    count = {"submitted": 0, "yielded": 0, "most": 0}

    class CountingPool(concurrent.futures.ThreadPoolExecutor):
        def submit(self, *args: Any, **kwargs: Any) -> Any:   # type: ignore[override]
            count["submitted"] += 1
            count["most"] = max(count["most"], count["submitted"] - count["yielded"])
            return super().submit(*args, **kwargs)

    monkeypatch.setattr(concurrent.futures, "ThreadPoolExecutor", CountingPool)
    lock = threading.Lock()
    given: dict[str, int] = {}
    first_wave = threading.Barrier(together, timeout=60)

    def work(run: dict[str, Any], plan: JobPlan, out: Path, *, threads: int, **flags: Any) -> dict[str, Any]:
        with lock:
            given[run["run_id"]] = threads
        if int(run["run_id"][3:]) < together:
            first_wave.wait()
        return {"run_id": run["run_id"]}

    ids = [f"run{i:02d}" for i in range(runs)]
    finished = []
    for status, _ in engines.process_local(work, [{"run_id": i} for i in ids], [1] * runs,
                                           JobPlan.given(ProcessingOptions()), Path("."), threads, {}):
        count["yielded"] += 1
        finished.append(status["run_id"])
    assert sorted(finished) == ids   # every run, once
    return count["most"], [given[i] for i in ids]


def test_a_long_job_keeps_a_run_more_than_the_cores_in_flight_one_thread_each(monkeypatch: pytest.MonkeyPatch) -> None:
    most, threads = run_fake_job(monkeypatch, cores=2, runs=12, threads=None, together=3)
    assert most == 3
    assert threads[:-1] == [1] * 11          # three runs solving on two cores: one thread each
    assert threads[-1] == 2                  # the last run alone: every core


def test_a_job_of_one_run_solves_on_every_core(monkeypatch: pytest.MonkeyPatch) -> None:
    assert run_fake_job(monkeypatch, cores=2, runs=1, threads=None) == (1, [2])
    assert run_fake_job(monkeypatch, cores=8, runs=1, threads=None) == (1, [8])


def test_many_cores_hold_at_most_the_memory_bound_of_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    most, threads = run_fake_job(monkeypatch, cores=16, runs=20, threads=None,
                                 together=engines.MAX_LOCAL_RUNS_IN_FLIGHT)
    assert most == engines.MAX_LOCAL_RUNS_IN_FLIGHT
    # the runs solving at once (all but one in Python) use the cores without more than one over
    assert all(t * (engines.MAX_LOCAL_RUNS_IN_FLIGHT - 1) <= 16 for t in threads[:-4])
    assert threads[-1] == 16


def test_threads_given_are_used_as_given_two_runs_at_a_time(monkeypatch: pytest.MonkeyPatch) -> None:
    most, threads = run_fake_job(monkeypatch, cores=2, runs=6, threads=1, together=2)
    assert most == 2 and threads == [1] * 6
