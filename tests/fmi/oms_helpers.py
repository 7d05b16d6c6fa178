"""Driving OMSimulator from the tests: the estimator FMU on recorded sensors (a CSV table component wired to
its inputs by a Lua script), its ``.mat`` results, and an independent composition of the SSP's two FMUs in
fmpy with OMSimulator's master semantics.

OMSimulator's fixed-step master adds its step to its time (``t += h``): after ``n`` steps of 0.1 s it stands
a few 1e-15 s short of ``n h`` and, given ``--stopTime = n h``, asks the FMUs for that remainder as a last
step, which the estimator refuses. Every run here stops at the master's own accumulated time instead
(:func:`postcapture.studies.estimator_ssp.accumulated_time`), and the table's time column holds those same
instants. Even so the table does not hand back its samples bit for bit: it finds instant ``t_k`` from the
row of the previous lookup and interpolates ``v_k-1 + (t_k - t_k-1) (v_k - v_k-1) / (t_k - t_k-1)``, which
differs from ``v_k`` in the last bit (1e-18 on a quaternion component). That rounding, not the FMU nor the
``.mat`` result (doubles), is what limits the comparison with the native estimates (a few 1e-11 of the mass
after 300 s; the same FMU in fmpy matches the native run to 2e-16).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

__all__ = ["ESTIMATES", "read_mat", "estimator_table", "run_estimator", "compose", "run_oms", "native_estimates",
           "rel_by_row"]

# the estimator outputs compared: mass, its sigma, the attitude quaternion and its three sigmas
ESTIMATES = ("target_mass", "target_mass_sigma", "q_BN_w", "q_BN_x", "q_BN_y", "q_BN_z", "attitude_sigma_x",
             "attitude_sigma_y", "attitude_sigma_z")


def read_mat(path: str | Path) -> dict:
    """The signals of an OMSimulator ``.mat`` result (the OpenModelica 'binTrans' layout, MATLAB v4): each
    name -> its values, one per row the master wrote, in double precision."""
    import scipy.io

    m = scipy.io.loadmat(str(path), chars_as_strings=False)

    def names(block) -> list[str]:  # one name per column, padded with blanks or NULs
        a = np.asarray(block)
        return ["".join(a[:, j]).replace("\x00", "").strip() for j in range(a.shape[1])]

    info = np.asarray(m["dataInfo"])
    out = {}
    for j, name in enumerate(names(m["name"])):
        block, index = int(info[0, j]), int(info[1, j])
        data = m["data_2" if block in (0, 2) else f"data_{block}"]
        row = np.sign(index) * data[abs(index) - 1, :]
        out[name] = row if block != 1 else np.full(m["data_2"].shape[1], row[0])
    return out


def on_times(result: dict, prefix: str, names) -> tuple[np.ndarray, np.ndarray]:
    """Time and the named signals (``prefix + name``), one row per communication point (OMSimulator writes
    each point before and after its step; the estimator's outputs only change in a step)."""
    t, first = np.unique(result["time"], return_index=True)
    return t, np.array([result[prefix + n][first] for n in names])


def rel_by_row(got: np.ndarray, want: np.ndarray) -> float:
    """Largest difference over the largest magnitude of the reference."""
    return float(np.max(np.abs(np.asarray(got) - want)) / np.max(np.abs(want)))


def estimator_table(star, gyro, accel, enc) -> dict:
    """The estimator's inputs as table columns, row ``k`` being what the cycle ``[t_k, t_k+1]`` reads: the star
    tracker and the encoders at ``t_k+1``, the gyro and the accelerometer's means over the cycle (the samples
    taken at ``t_k``), as the native scheme pairs them. A missing sample is 0 with its flag 0."""
    cols = {}

    def add(prefix, labels, values, shift, flag):
        values = np.asarray(values, dtype=float)
        if shift:  # the last row is never read by a step: repeat the last sample
            values = np.concatenate([values[:, 1:], values[:, -1:]], axis=1)
        ok = np.all(np.isfinite(values), axis=0)
        for label, row in zip(labels, values):
            cols[prefix + label] = np.where(ok, np.nan_to_num(row), 0.0)
        cols[flag] = ok.astype(float)

    add("star_q_", "wxyz", star, True, "star_valid")
    add("gyro_", "xyz", gyro, False, "gyro_valid")
    add("accel_", "xyz", accel, False, "accel_valid")
    add("encoder_", [str(i + 1) for i in range(np.shape(enc)[0])], enc, True, "encoders_valid")
    return cols


def run_oms(exe: str, args: list[str], cwd: Path, timeout: float) -> str:
    """Run OMSimulator; its log (it exits 0 even when it logged errors: the caller checks the log)."""
    proc = subprocess.run([exe, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text[-3000:]
    return text


def run_estimator(exe: str, fmu: Path, columns: dict, q0, step: float, stop: float, folder: Path,
                  timeout: float) -> tuple[np.ndarray, np.ndarray, str]:
    """The estimator FMU in OMSimulator, fed from a CSV table (times: the master's own accumulated instants
    up to ``stop``); returns the times, the :data:`ESTIMATES` (rows) and the log."""
    n = len(next(iter(columns.values())))
    times = [0.0]
    for _ in range(n - 1):
        times.append(times[-1] + step)
    assert times[-1] == stop
    table = folder / "inputs.csv"
    with open(table, "w") as f:
        f.write(",".join(["time", *columns]) + "\n")
        for k in range(n):
            f.write(",".join([repr(times[k])] + [repr(float(c[k])) for c in columns.values()]) + "\n")
    lines = [
        'oms_setTempDirectory("./tmp")', 'oms_newModel("est")', 'oms_addSystem("est.root", oms_system_wc)',
        f'oms_addSubModel("est.root.estimator", "{fmu}")', f'oms_addSubModel("est.root.recorded", "{table}")',
    ]
    lines += [f'oms_addConnection("est.root.recorded.{c}", "est.root.estimator.{c}")' for c in columns]
    lines += [f'oms_setReal("est.root.estimator.q0_BN_{a}", {float(v)!r})' for a, v in zip("wxyz", q0)]
    lines += [f'oms_setFixedStepSize("est.root", {float(step)!r})', f'oms_setStopTime("est", {float(stop)!r})',
              'oms_setResultFile("est", "estimates.mat")', 'oms_instantiate("est")', 'oms_initialize("est")',
              'oms_simulate("est")', 'oms_terminate("est")', 'oms_delete("est")']
    (folder / "run.lua").write_text("\n".join(lines) + "\n")
    log = run_oms(exe, ["run.lua"], folder, timeout)
    t, values = on_times(read_mat(folder / "estimates.mat"), "est.root.estimator.", ESTIMATES)
    return t, values, log


def native_estimates(result) -> np.ndarray:
    """The :data:`ESTIMATES` of a native case (rows), on its filter grid."""
    sigma = np.sqrt(np.einsum("iik->ik", result.attitude.P)[:3])
    return np.vstack([result.mass, result.mass_sigma, result.attitude.q_BN, sigma])


# which plant output feeds which estimator input in the SSP (estimator_ssp.scheme_connections)
def _pairs(n_arm: int):
    pairs = [(f"q_BN_{a}", f"star_q_{a}") for a in "wxyz"] + [(f"gyro_mean_{a}", f"gyro_{a}") for a in "xyz"]
    pairs += [(f"accel_mean_{a}", f"accel_{a}") for a in "xyz"]
    return pairs + [(f"arm_q_{i + 1}", f"encoder_{i + 1}") for i in range(n_arm)]


def compose(plant_fmu: Path, estimator_fmu: Path, step: float, n: int, *, gauss_seidel: bool = False,
            extra=()) -> tuple[np.ndarray, float | None]:
    """The plant and the estimator FMUs run side by side in fmpy, written from the FMI calls alone: every
    valid flag 1, commanded inputs 0, and at each ``t_k`` the estimator's sensor inputs set from the plant's
    outputs at ``t_k`` before both step (a Jacobi master, as OMSimulator's; the SSP's plant runs one period
    ahead, so those are the sensors of ``[t_k, t_k+1]``), or with ``gauss_seidel`` from its outputs at
    ``t_k+1`` (the plant steps first). Returns the :data:`ESTIMATES`
    and the ``extra`` outputs (rows) at ``t_0 .. t_m``, and the time of the cycle the estimator refused
    (``t_m``; None when it ran all ``n``). Time runs as in OMSimulator, ``t_k+1 = t_k + step`` (the plant's
    embedded manoeuvre is a function of time: ``k step`` instead moves it by a few 1e-15 s, which a filter
    that has diverged amplifies to 1e-5 within 100 s)."""
    from fmpy.fmi1 import FMICallException
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    def slave(path, name):
        md = read_model_description(str(path))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        return fmu, vr

    plant, pv = slave(plant_fmu, "plant")
    est, ev = slave(estimator_fmu, "estimator")
    flags = ["star_valid", "gyro_valid", "accel_valid", "encoders_valid"]
    est.setReal([ev[f] for f in flags], [1.0] * len(flags))
    plant.exitInitializationMode()
    est.exitInitializationMode()
    pairs = _pairs(sum(1 for name in ev if name.startswith("encoder_")))
    outputs, inputs = [pv[a] for a, _ in pairs], [ev[b] for _, b in pairs]
    wanted = [ev[name] for name in (*ESTIMATES, *extra)]
    hist, failed, t = [est.getReal(wanted)], None, 0.0
    try:
        for _ in range(n):
            t_next = t + step  # OMSimulator's time arithmetic: the step taken is t_next - t, not step
            if gauss_seidel:
                plant.doStep(t, t_next - t)
                est.setReal(inputs, plant.getReal(outputs))
            else:
                est.setReal(inputs, plant.getReal(outputs))
                plant.doStep(t, t_next - t)
            try:
                est.doStep(t, t_next - t)
            except FMICallException:
                failed = t
                break
            hist.append(est.getReal(wanted))
            t = t_next
    finally:
        plant.terminate()
        plant.freeInstance()
        if failed is None:
            est.terminate()
        est.freeInstance()
    return np.array(hist).T, failed
