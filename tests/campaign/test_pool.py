"""Worker processes: errors come back as raised (a bug with its traceback), and stopping is prompt."""

import os
import time

import pytest

from postcapture.studies.pool import run_jobs
from postcapture.core.errors import FilterDivergenceError, Problem, ScenarioError, WorkerError


def square(payload, progress):
    return payload["case"], payload["x"] ** 2


def user_error(payload, progress):
    raise ScenarioError([Problem("estimation.seed", "an integer >= 0", "-1")], "job")


def diverge(payload, progress):
    raise FilterDivergenceError("mekf", 12.5, "non-finite covariance")


def bug(payload, progress):
    return payload["case"], {}["no such key"]


def slow(payload, progress):
    time.sleep(60)
    return payload["case"], os.getpid()


def test_results_in_order_and_progress():
    seen = []
    out = run_jobs([(square, {"case": f"c{i}", "x": i}) for i in range(4)], workers=2,
                   on_done=lambda name, done, total: seen.append((name, done, total)))
    assert out == {f"c{i}": i * i for i in range(4)}
    assert seen[-1][1:] == (4, 4)


@pytest.mark.parametrize("workers", [1, 2])
def test_user_errors_arrive_as_raised(workers):
    with pytest.raises(ScenarioError) as err:
        run_jobs([(square, {"case": "a", "x": 1}), (user_error, {"case": "b"})], workers=workers)
    assert [str(p) for p in err.value.problems] == ["estimation.seed: expected an integer >= 0, found -1"]
    with pytest.raises(FilterDivergenceError) as err:
        run_jobs([(square, {"case": "a", "x": 1}), (diverge, {"case": "b"})], workers=workers)
    assert (err.value.filter_name, err.value.time) == ("mekf", 12.5)


def test_a_bug_in_a_worker_comes_back_with_its_traceback():
    with pytest.raises(WorkerError, match=r"internal error in worker job 'bug\(b\)': KeyError: 'no such key'") as err:
        run_jobs([(square, {"case": "a", "x": 1}), (bug, {"case": "b"})], workers=2)
    assert "Traceback" in err.value.traceback and 'return payload["case"], {}["no such key"]' in err.value.traceback


def test_a_failure_stops_the_other_workers_at_once():
    t0 = time.monotonic()
    with pytest.raises(WorkerError):
        run_jobs([(slow, {"case": "s"}), (bug, {"case": "b"}), (slow, {"case": "t"})], workers=2)
    assert time.monotonic() - t0 < 10  # not the 60 s the slow job would take
