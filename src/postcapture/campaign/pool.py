"""Run independent jobs (the main job's cases) in worker processes, or in this process.

A job is ``(function, payload)``; ``function(payload, progress)`` returns ``(name, value)`` and may call
``progress(fraction)`` as it goes. The functions must be importable at module level (they are pickled
to the workers).

Process handling:

* each worker has a top-level handler (:func:`guarded`): errors a user can cause (postcapture's own,
  ``OSError``, ``MemoryError``) reach the parent as raised; anything else is a bug and comes back as a
  :class:`~postcapture.core.errors.WorkerError` carrying the worker's traceback as text;
* workers ignore SIGINT: a Ctrl-C in a terminal (sent to the whole process group) is handled by the
  parent alone, which stops the workers at once (terminate, then kill) and re-raises
  ``KeyboardInterrupt``; no worker prints a traceback and the parent does not wait for running jobs.
"""

from __future__ import annotations

import logging
import multiprocessing
import signal
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed

from postcapture.core.errors import PostcaptureError, WorkerError

__all__ = ["run_jobs", "guarded", "worker_signals", "dask_setup"]

logger = logging.getLogger(__name__)

_STOP_WAIT_S = 2.0  # how long terminated workers get to exit before they are killed


def worker_signals() -> None:
    """Signal dispositions of a worker process: SIGINT ignored (the parent handles it), SIGTERM default.

    A forked worker inherits the parent's handlers; the CLI's SIGTERM handler raises in Python, which in
    a worker would print a traceback when the parent stops it.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def dask_setup(worker) -> None:
    """Dask's preload hook: a worker of a local cluster (``preload=["postcapture.campaign.pool"]``) leaves
    Ctrl-C to the parent, as the case pool's workers do (no KeyboardInterrupt traceback from each).

    Its own Dask logging is kept to critical messages: a task's error reaches the parent with the task,
    and what a worker logs while the parent stops the cluster (heartbeats to a scheduler already gone,
    with their tracebacks) is noise on the terminal.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed").setLevel(logging.CRITICAL)


def guarded(fn: Callable, payload, label: str):
    """Call ``fn(payload, None)`` in a worker with the top-level handler of the module text."""
    try:
        return fn(payload, None)
    except (PostcaptureError, OSError, MemoryError):
        raise
    except Exception as exc:  # a bug: its traceback exists only here, so it travels as text
        raise WorkerError(label, type(exc).__name__, str(exc), traceback.format_exc()) from None


def _label(fn: Callable, payload) -> str:
    case = payload.get("case") if isinstance(payload, dict) else None
    return f"{fn.__name__}({case})" if case else fn.__name__


def _stop(pool: ProcessPoolExecutor) -> None:
    """Stop every worker now: cancel queued jobs, terminate running ones, kill the stubborn."""
    processes = list(getattr(pool, "_processes", {}).values())  # no public handle before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        if proc.is_alive():
            proc.terminate()
    for proc in processes:
        proc.join(_STOP_WAIT_S)
        if proc.is_alive():
            proc.kill()
            proc.join(_STOP_WAIT_S)


def run_jobs(
    jobs: Sequence[tuple[Callable, dict]],
    *,
    workers: int = 2,
    on_done: Callable[[str, int, int], None] | None = None,
) -> dict:
    """Run every job and return ``{name: value}``.

    Parameters
    ----------
    jobs : sequence of (callable, dict)
        ``fn(payload, progress) -> (name, value)``.
    workers : int
        Worker processes; 1 (or a single job) runs everything in this process.
    on_done : callable(name, done, total), optional
        Called as each job finishes (in the order they finish).

    Raises
    ------
    WorkerError
        When a job fails with an unexpected error (a bug) in a worker. On any failure the other
        workers are stopped at once.
    KeyboardInterrupt
        On Ctrl-C, after every worker has been stopped.
    """
    outputs: dict = {}
    total = len(jobs)
    if workers > 1 and total > 1:
        ctx = multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=worker_signals)
        try:
            futures = [pool.submit(guarded, fn, payload, _label(fn, payload)) for fn, payload in jobs]
            for i, fut in enumerate(as_completed(futures)):  # a failure is seen as soon as it happens
                name, value = fut.result()
                outputs[name] = value
                if on_done is not None:
                    on_done(name, i + 1, total)
        except BaseException:
            _stop(pool)
            raise
        pool.shutdown(wait=True)
    else:
        for i, (fn, payload) in enumerate(jobs):
            name, value = fn(payload, None)
            outputs[name] = value
            if on_done is not None:
                on_done(name, i + 1, total)
    return outputs
