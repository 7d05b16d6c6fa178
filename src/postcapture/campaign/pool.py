"""Run independent jobs (the main job's cases) in worker processes, or in this process.

A job is ``(function, payload)``; ``function(payload, progress)`` returns ``(name, value)`` and may call
``progress(fraction)`` as it goes. The functions must be importable at module level (they are pickled
to the workers).
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

__all__ = ["run_jobs"]


def _call(fn, payload):
    return fn(payload, None)


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
        Called as each job finishes.
    """
    outputs: dict = {}
    total = len(jobs)
    if workers > 1 and total > 1:
        ctx = multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            futures = [pool.submit(_call, fn, payload) for fn, payload in jobs]
            for i, fut in enumerate(futures):
                name, value = fut.result()
                outputs[name] = value
                if on_done is not None:
                    on_done(name, i + 1, total)
    else:
        for i, (fn, payload) in enumerate(jobs):
            name, value = fn(payload, None)
            outputs[name] = value
            if on_done is not None:
                on_done(name, i + 1, total)
    return outputs
