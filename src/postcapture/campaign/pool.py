"""Run independent jobs (the main job's cases) in worker processes, or in this process.

A job is ``(function, payload)`` or ``(function, payload, label)``; ``function(payload, progress)``
returns ``(name, value)`` and may call ``progress(fraction)`` as it goes. The functions must be
importable at module level (they are pickled to the workers).

Progress from the workers travels back on a multiprocessing queue, handed to each worker when it
starts; this process reads it while it waits for the results and passes ``(label, fraction)`` on.
"""

from __future__ import annotations

import multiprocessing
import queue as queue_module
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

__all__ = ["run_jobs"]

_progress_queue = None  # in a worker: where its jobs' progress goes (set by _init_worker)

POLL_S = 0.1
"""How often this process reads the workers' progress while it waits (s)."""


def _init_worker(progress_queue) -> None:
    global _progress_queue
    _progress_queue = progress_queue


def _call(fn, payload, label):
    q = _progress_queue
    return fn(payload, None if q is None else (lambda fraction: q.put((label, float(fraction)))))


def _drain(progress_queue, on_progress) -> None:
    while True:
        try:
            label, fraction = progress_queue.get_nowait()
        except queue_module.Empty:
            return
        on_progress(label, fraction)


def _labelled(jobs) -> list[tuple[Callable, dict, str]]:
    return [(job[0], job[1], str(job[2]) if len(job) > 2 else str(i)) for i, job in enumerate(jobs)]


def run_jobs(
    jobs: Sequence[tuple],
    *,
    workers: int = 2,
    on_done: Callable[[str, int, int], None] | None = None,
    on_progress: Callable[[str, float], None] | None = None,
) -> dict:
    """Run every job and return ``{name: value}`` (in the order of ``jobs``).

    Parameters
    ----------
    jobs : sequence of (callable, dict) or (callable, dict, str)
        ``fn(payload, progress) -> (name, value)``, and an optional label for the progress reports
        (default: the job's index).
    workers : int
        Worker processes; 1 (or a single job) runs everything in this process.
    on_done : callable(name, done, total), optional
        Called as each job finishes, in the order they finish.
    on_progress : callable(label, fraction), optional
        Called, in this process, with the fractions each job reports.
    """
    labelled = _labelled(jobs)
    total = len(labelled)
    results: list = [None] * total
    if workers > 1 and total > 1:
        ctx = (multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods()
               else multiprocessing.get_context())
        progress_queue = ctx.Queue() if on_progress is not None else None
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                 initargs=(progress_queue,)) as pool:
            futures = {pool.submit(_call, fn, payload, label): i for i, (fn, payload, label) in enumerate(labelled)}
            pending = set(futures)
            done_count = 0
            while pending:
                finished, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
                if progress_queue is not None:
                    _drain(progress_queue, on_progress)
                for fut in sorted(finished, key=futures.get):
                    results[futures[fut]] = fut.result()
                    done_count += 1
                    if on_done is not None:
                        on_done(results[futures[fut]][0], done_count, total)
        if progress_queue is not None:
            progress_queue.close()
    else:
        for i, (fn, payload, label) in enumerate(labelled):
            report = None if on_progress is None else (lambda fraction, label=label: on_progress(label, fraction))
            results[i] = fn(payload, report)
            if on_done is not None:
                on_done(results[i][0], i + 1, total)
    return dict(results)
