"""Run independent jobs (the main job's cases) in worker processes, or in this process.

A job is ``(function, payload)`` or ``(function, payload, label)``; ``function(payload, progress)``
returns ``(name, value)`` and may call ``progress(fraction)`` as it goes. The functions must be
importable at module level (they are pickled to the workers).

Progress from the workers travels back on a multiprocessing queue, handed to each worker when it
starts; this process reads it while it waits for the results and passes ``(label, fraction)`` on.

Process handling:

* each worker has a top-level handler (:func:`_call`): errors a user can cause (postcapture's own,
  ``OSError``, ``MemoryError``) reach the parent as raised; anything else is a bug and comes back as a
  :class:`~postcapture.core.errors.WorkerError` carrying the worker's traceback as text;
* workers ignore SIGINT: a Ctrl-C in a terminal (sent to the whole process group) is handled by the
  parent alone, which stops the workers at once (terminate, then kill) and re-raises
  ``KeyboardInterrupt``; no worker prints a traceback and the parent does not wait for running jobs.
  The first failure of a job stops the others the same way.
"""

from __future__ import annotations

import logging
import multiprocessing
import queue as queue_module
import signal
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from postcapture.core.errors import PostcaptureError, WorkerError

__all__ = ["run_jobs", "worker_signals", "dask_setup"]

logger = logging.getLogger(__name__)

_progress_queue = None  # in a worker: where its jobs' progress goes (set by _init_worker)

POLL_S = 0.1
"""How often this process reads the workers' progress while it waits (s)."""

_STOP_WAIT_S = 2.0  # how long terminated workers get to exit before they are killed


def worker_signals() -> None:
    """Signal dispositions of a worker process: SIGINT ignored (the parent handles it), SIGTERM default.

    A forked worker inherits the parent's handlers; the CLI's SIGTERM handler raises in Python, which in
    a worker would print a traceback when the parent stops it.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def dask_setup(worker) -> None:
    """Dask's preload hook: a worker of a local cluster (``preload=["postcapture.studies.pool"]``) leaves
    Ctrl-C to the parent, as the case pool's workers do (no KeyboardInterrupt traceback from each).

    Its own Dask logging is kept to critical messages: a task's error reaches the parent with the task,
    and what a worker logs while the parent stops the cluster (heartbeats to a scheduler already gone,
    with their tracebacks) is noise on the terminal.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed").setLevel(logging.CRITICAL)


def _init_worker(progress_queue) -> None:
    global _progress_queue
    worker_signals()
    _progress_queue = progress_queue


def _call(fn, payload, label):
    """A job in a worker, under the top-level handler of the module text."""
    q = _progress_queue
    try:
        return fn(payload, None if q is None else (lambda fraction: q.put((label, float(fraction)))))
    except (PostcaptureError, OSError, MemoryError):
        raise
    except Exception as exc:  # a bug: its traceback exists only here, so it travels as text
        case = payload.get("case") if isinstance(payload, dict) else None
        raise WorkerError(f"{fn.__name__}({case or label})", type(exc).__name__, str(exc),
                          traceback.format_exc()) from None


def _drain(progress_queue, on_progress) -> None:
    while True:
        try:
            label, fraction = progress_queue.get_nowait()
        except queue_module.Empty:
            return
        on_progress(label, fraction)


def _labelled(jobs) -> list[tuple[Callable, dict, str]]:
    return [(job[0], job[1], str(job[2]) if len(job) > 2 else str(i)) for i, job in enumerate(jobs)]


def _stop(pool: ProcessPoolExecutor) -> None:
    """Stop every worker now: cancel queued jobs, terminate running ones, kill the stubborn."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # no public handle before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        if proc.is_alive():
            proc.terminate()
    for proc in processes:
        proc.join(_STOP_WAIT_S)
        if proc.is_alive():
            proc.kill()
            proc.join(_STOP_WAIT_S)
    _forget_manager(pool)


def _forget_manager(pool: ProcessPoolExecutor) -> None:
    """Let the pool's manager thread end, and keep Python's exit hook from waking it again.

    At exit, ``concurrent.futures`` wakes every pool's manager thread through a pipe that the thread closes
    when it ends; on Python 3.11 the two can race, and the exit hook then prints an ``OSError`` traceback
    ("Bad file descriptor") after the command's one line. A stopped pool's thread has nothing left to do.
    """
    import concurrent.futures.process as cfp

    thread = getattr(pool, "_executor_manager_thread", None)  # no public handle
    if thread is None:
        return
    thread.join(_STOP_WAIT_S)
    if not thread.is_alive():
        getattr(cfp, "_threads_wakeups", {}).pop(thread, None)


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

    Raises
    ------
    WorkerError
        When a job fails with an unexpected error (a bug) in a worker. On any failure the other
        workers are stopped at once.
    KeyboardInterrupt
        On Ctrl-C, after every worker has been stopped.
    """
    labelled = _labelled(jobs)
    total = len(labelled)
    results: list = [None] * total
    if workers > 1 and total > 1:
        ctx = (multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods()
               else multiprocessing.get_context())
        progress_queue = ctx.Queue() if on_progress is not None else None
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                   initargs=(progress_queue,))
        try:
            futures = {pool.submit(_call, fn, payload, label): i for i, (fn, payload, label) in enumerate(labelled)}
            pending = set(futures)
            done_count = 0
            while pending:
                finished, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
                if progress_queue is not None:
                    _drain(progress_queue, on_progress)
                for fut in sorted(finished, key=futures.get):
                    results[futures[fut]] = fut.result()  # a failure is seen as soon as it happens
                    done_count += 1
                    if on_done is not None:
                        on_done(results[futures[fut]][0], done_count, total)
        except BaseException:
            _stop(pool)
            raise
        finally:
            if progress_queue is not None:
                progress_queue.close()
        pool.shutdown(wait=True)
    else:
        for i, (fn, payload, label) in enumerate(labelled):
            report = None if on_progress is None else (lambda fraction, label=label: on_progress(label, fraction))
            results[i] = fn(payload, report)
            if on_done is not None:
                on_done(results[i][0], i + 1, total)
    return dict(results)
