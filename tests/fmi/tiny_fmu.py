# ruff: noqa: E501 - C sources and XML templates in strings
"""Small C co-simulation FMUs built at test time with gcc (no downloads), for the import tests.

The plant is a torque-free rigid body (inertia diag(I1, I1, I3), axisymmetric): state
``x = [q_w, q_x, q_y, q_z, w_x, w_y, w_z]`` (q_BN scalar first, omega_BN_B), integrated with RK4 substeps
in ``fmi2DoStep``; outputs ``dw_x..dw_z`` (the body angular acceleration, used as the "accelerometer");
inputs ``x_corr_1..7`` and ``reset`` (the postcapture correction convention).

:func:`build_tiny_fmu3` builds the same plant as an FMI 3.0 co-simulation FMU.

Variants (compile-time): ``ok``; ``discard`` / ``error`` (``fmi2DoStep`` returns that status);
``nostate`` (no FMU-state support, ``canGetAndSetFMUstate="false"``); ``me_only`` (the model
description declares model exchange only).
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

__all__ = ["I1", "I3", "MAPPING", "build_tiny_fmu", "build_tiny_fmu3"]

I1, I3 = 2.0, 3.0
GUID = "{5d1f3c2e-7a47-4c55-9d7e-0c6a5b1e2f10}"

DYNAMICS = r"""
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NX 7
typedef struct { double t, x[NX], xc[NX], reset; } core_t;

static void f(const double* x, double* d) {
    double qw = x[0], qx = x[1], qy = x[2], qz = x[3], wx = x[4], wy = x[5], wz = x[6];
    d[0] = 0.5 * (-qx * wx - qy * wy - qz * wz);
    d[1] = 0.5 * (qw * wx + qy * wz - qz * wy);
    d[2] = 0.5 * (qw * wy + qz * wx - qx * wz);
    d[3] = 0.5 * (qw * wz + qx * wy - qy * wx);
    d[4] = (I1V - I3V) / I1V * wy * wz;
    d[5] = (I3V - I1V) / I1V * wz * wx;
    d[6] = 0.0;
}

static void rk4(double* x, double h) {
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX];
    int i;
    f(x, k1); for (i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k1[i];
    f(y, k2); for (i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k2[i];
    f(y, k3); for (i = 0; i < NX; i++) y[i] = x[i] + h * k3[i];
    f(y, k4); for (i = 0; i < NX; i++) x[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
}
"""

C_SOURCE = (
    DYNAMICS
    + r"""
#include "fmi2Functions.h"
typedef struct { core_t c; fmi2CallbackFunctions cb; char name[64]; } inst_t;

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean l, size_t n, const fmi2String s[]) { return fmi2OK; }
fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions* cb, fmi2Boolean vis, fmi2Boolean log) {
    inst_t* I = calloc(1, sizeof(inst_t));
    double x0[NX] = {1, 0, 0, 0, 0.3, 0.0, 0.5};
    I->cb = *cb;
    strncpy(I->name, name, 63);
    memcpy(I->c.x, x0, sizeof x0);
    memcpy(I->c.xc, x0, sizeof x0);
    return I;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real t0, fmi2Boolean d, fmi2Real e) {
    ((inst_t*)c)->c.t = t0; return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { return fmi2OK; }

/* vr: 0..6 state, 7..9 dw (outputs), 10..16 x_corr, 17 reset */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    inst_t* I = c; double d[NX]; size_t k;
    f(I->c.x, d);
    for (k = 0; k < n; k++) {
        if (vr[k] < 7) v[k] = I->c.x[vr[k]];
        else if (vr[k] < 10) v[k] = d[vr[k] - 3];
        else if (vr[k] < 17) v[k] = I->c.xc[vr[k] - 10];
        else if (vr[k] == 17) v[k] = I->c.reset;
        else return fmi2Error;
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    inst_t* I = c; size_t k;
    for (k = 0; k < n; k++) {
        if (vr[k] >= 10 && vr[k] < 17) I->c.xc[vr[k] - 10] = v[k];
        else if (vr[k] == 17) I->c.reset = v[k];
        else return fmi2Error;
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return n ? fmi2Error : fmi2OK; }

#ifdef NOSTATE
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) { return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) { return fmi2Error; }
#else
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) {
    if (!*s) *s = malloc(sizeof(core_t));
    memcpy(*s, &((inst_t*)c)->c, sizeof(core_t)); return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { memcpy(&((inst_t*)c)->c, s, sizeof(core_t)); return fmi2OK; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) { free(*s); *s = NULL; return fmi2OK; }
#endif
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t* n) { return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate* s) { return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
    const fmi2ValueReference k[], size_t nk, const fmi2Real dk[], fmi2Real du[]) { return fmi2Error; }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer o[], const fmi2Real v[]) { return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer o[], fmi2Real v[]) { return fmi2Error; }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean flag) {
    inst_t* I = c; int k, n = 100;
#ifdef FAIL_STATUS
    I->cb.logger(I->cb.componentEnvironment, I->name, FAIL_STATUS, "logStatusError", "tiny: failing on purpose");
    return FAIL_STATUS;
#endif
    if (I->c.reset > 0.5) memcpy(I->c.x, I->c.xc, sizeof I->c.x);
    for (k = 0; k < n; k++) rk4(I->c.x, h / n);
    I->c.t = t + h;
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* v) { return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* v) { return fmi2Discard; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* v) { return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* v) { return fmi2Discard; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* v) { return fmi2Discard; }
"""
)

_NAMES = ["q_w", "q_x", "q_y", "q_z", "w_x", "w_y", "w_z", "dw_x", "dw_y", "dw_z"]


def _xml(kind: str) -> str:
    state = "false" if kind == "nostate" else "true"
    if kind == "me_only":
        interface = '<ModelExchange modelIdentifier="tiny"/>'
    else:
        interface = f'<CoSimulation modelIdentifier="tiny" canGetAndSetFMUstate="{state}" canHandleVariableCommunicationStepSize="true"/>'
    rows = []
    start = [1, 0, 0, 0, 0.3, 0.0, 0.5]
    for i, name in enumerate(_NAMES):
        init = ' initial="exact"' if i < 7 else ' initial="calculated"'
        st = f' start="{start[i]}"' if i < 7 else ""
        rows.append(
            f'<ScalarVariable name="{name}" valueReference="{i}" causality="output" variability="continuous"{init}>'
            f"<Real{st}/></ScalarVariable>"
        )
    for i in range(7):
        rows.append(
            f'<ScalarVariable name="x_corr_{i + 1}" valueReference="{10 + i}" causality="input" variability="discrete">'
            f'<Real start="{start[i]}"/></ScalarVariable>'
        )
    rows.append(
        '<ScalarVariable name="reset" valueReference="17" causality="input" variability="discrete"><Real start="0"/></ScalarVariable>'
    )
    outputs = "".join(f'<Unknown index="{i + 1}"/>' for i in range(10))
    init = "".join(f'<Unknown index="{i + 1}"/>' for i in range(7, 10))
    return (
        f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="2.0" modelName="tiny" guid="{GUID}" '
        f'numberOfEventIndicators="0">{interface}<ModelVariables>{"".join(rows)}</ModelVariables>'
        f"<ModelStructure><Outputs>{outputs}</Outputs><InitialUnknowns>{init}</InitialUnknowns></ModelStructure>"
        f"</fmiModelDescription>\n"
    )


MAPPING = """
format = 1
[state]
variables = ["q_w", "q_x", "q_y", "q_z", "w_x", "w_y", "w_z"]
kinematics = "quaternion"
attitude = ["q_w", "q_x", "q_y", "q_z"]
rate = ["w_x", "w_y", "w_z"]
[correction]
inputs = ["x_corr_1", "x_corr_2", "x_corr_3", "x_corr_4", "x_corr_5", "x_corr_6", "x_corr_7"]
reset = "reset"
[measurement]
accel = ["dw_x", "dw_y", "dw_z"]
joint_accel = []
"""


def build_tiny_fmu(directory: Path, kind: str = "ok") -> Path:
    """Compile and zip a tiny FMU variant (see the module docstring); writes ``<kind>.fmu`` and ``<kind>.toml``."""
    import fmpy

    directory = Path(directory)
    root = directory / f"tiny_{kind}"
    if root.exists():
        shutil.rmtree(root)
    (root / "sources").mkdir(parents=True)
    (root / "binaries" / "linux64").mkdir(parents=True)
    src = root / "sources" / "tiny.c"
    src.write_text(C_SOURCE)
    defs = [f"-DI1V={I1}", f"-DI3V={I3}"]
    if kind == "discard":
        defs.append("-DFAIL_STATUS=fmi2Discard")
    elif kind == "error":
        defs.append("-DFAIL_STATUS=fmi2Error")
    elif kind == "nostate":
        defs.append("-DNOSTATE")
    c_code = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(
        [
            "gcc",
            "-shared",
            "-fPIC",
            "-O1",
            "-w",
            *defs,
            "-I",
            str(c_code),
            str(src),
            "-o",
            str(root / "binaries" / "linux64" / "tiny.so"),
            "-lm",
        ],
        check=True,
    )
    (root / "modelDescription.xml").write_text(_xml(kind))
    out = directory / f"{kind}.fmu"
    with zipfile.ZipFile(out, "w") as zf:
        for p in sorted(root.rglob("*")):
            if p.is_file():
                zf.write(p, p.relative_to(root).as_posix())
    out.with_suffix(".toml").write_text(MAPPING)
    return out


# ---------------------------------------------------------------------------------------------- FMI 3.0
C3_SOURCE = (
    DYNAMICS
    + r"""
#include <stdbool.h>
#include <stddef.h>
typedef struct { core_t c; } inst_t;

const char* fmi3GetVersion(void) { return "3.0"; }
void* fmi3InstantiateCoSimulation(const char* name, const char* token, const char* res, bool visible, bool log,
    bool event, bool early, const unsigned int* req, size_t nreq, void* env, void* logger, void* update) {
    inst_t* I = calloc(1, sizeof(inst_t));
    double x0[NX] = {1, 0, 0, 0, 0.3, 0.0, 0.5};
    memcpy(I->c.x, x0, sizeof x0);
    memcpy(I->c.xc, x0, sizeof x0);
    return I;
}
int fmi3EnterInitializationMode(void* c, bool tolDef, double tol, double t0, bool stopDef, double stop) {
    ((inst_t*)c)->c.t = t0; return 0;
}
int fmi3ExitInitializationMode(void* c) { return 0; }
int fmi3Terminate(void* c) { return 0; }
void fmi3FreeInstance(void* c) { free(c); }
int fmi3GetFloat64(void* c, const unsigned int vr[], size_t n, double v[], size_t nv) {
    inst_t* I = c; double d[NX]; size_t k;
    f(I->c.x, d);
    for (k = 0; k < n; k++) {
        if (vr[k] < 7) v[k] = I->c.x[vr[k]];
        else if (vr[k] < 10) v[k] = d[vr[k] - 3];
        else if (vr[k] < 17) v[k] = I->c.xc[vr[k] - 10];
        else if (vr[k] == 17) v[k] = I->c.reset;
        else if (vr[k] == 100) v[k] = I->c.t;
        else return 3;
    }
    return 0;
}
int fmi3SetFloat64(void* c, const unsigned int vr[], size_t n, const double v[], size_t nv) {
    inst_t* I = c; size_t k;
    for (k = 0; k < n; k++) {
        if (vr[k] >= 10 && vr[k] < 17) I->c.xc[vr[k] - 10] = v[k];
        else if (vr[k] == 17) I->c.reset = v[k];
        else return 3;
    }
    return 0;
}
int fmi3DoStep(void* c, double t, double h, bool noSet, bool* event, bool* term, bool* early, double* last) {
    inst_t* I = c; int k, n = 100;
    if (I->c.reset > 0.5) memcpy(I->c.x, I->c.xc, sizeof I->c.x);
    for (k = 0; k < n; k++) rk4(I->c.x, h / n);
    I->c.t = t + h;
    *event = false; *term = false; *early = false; *last = t + h;
    return 0;
}
int fmi3GetFMUState(void* c, void** s) {
    if (!*s) *s = malloc(sizeof(core_t));
    memcpy(*s, &((inst_t*)c)->c, sizeof(core_t)); return 0;
}
int fmi3SetFMUState(void* c, void* s) { memcpy(&((inst_t*)c)->c, s, sizeof(core_t)); return 0; }
int fmi3FreeFMUState(void* c, void** s) { free(*s); *s = NULL; return 0; }
"""
)

_FMI3_DONE = {
    "fmi3GetVersion",
    "fmi3InstantiateCoSimulation",
    "fmi3EnterInitializationMode",
    "fmi3ExitInitializationMode",
    "fmi3Terminate",
    "fmi3FreeInstance",
    "fmi3GetFloat64",
    "fmi3SetFloat64",
    "fmi3DoStep",
    "fmi3GetFMUState",
    "fmi3SetFMUState",
    "fmi3FreeFMUState",
}


def _xml3(interface: str = "CoSimulation", flags: str = "") -> str:
    start = [1, 0, 0, 0, 0.3, 0.0, 0.5]
    rows = ['<Float64 name="time" valueReference="100" causality="independent" variability="continuous"/>']
    for i, name in enumerate(_NAMES):
        extra = f' initial="exact" start="{start[i]}"' if i < 7 else ' initial="calculated"'
        rows.append(
            f'<Float64 name="{name}" valueReference="{i}" causality="output" variability="continuous"{extra}/>'
        )
    for i in range(7):
        rows.append(
            f'<Float64 name="x_corr_{i + 1}" valueReference="{10 + i}" causality="input" variability="discrete" '
            f'start="{start[i]}"/>'
        )
    rows.append(
        '<Float64 name="reset" valueReference="17" causality="input" variability="discrete" start="0"/>'
    )
    outputs = "".join(f'<Output valueReference="{i}"/>' for i in range(10))
    init = "".join(f'<InitialUnknown valueReference="{i}"/>' for i in range(7, 10))
    return (
        f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="3.0" modelName="tiny3" '
        f'instantiationToken="{GUID}"><{interface} modelIdentifier="tiny3" canGetAndSetFMUState="true" '
        f'canHandleVariableCommunicationStepSize="true"{flags}/><ModelVariables>{"".join(rows)}</ModelVariables>'
        f"<ModelStructure>{outputs}{init}</ModelStructure></fmiModelDescription>\n"
    )


def build_tiny_fmu3(directory: Path, *, interface: str = "CoSimulation", flags: str = "", name: str = "tiny3") -> Path:
    """Compile and zip the FMI 3.0 variant; writes ``<name>.fmu`` and ``<name>.toml``.

    ``interface`` is the interface element (``CoSimulation`` or ``ScheduledExecution``), ``flags`` extra
    attributes on it (e.g. ``' providesDirectionalDerivatives="true"'``).
    """
    from fmpy import platform_tuple
    from fmpy.fmi3 import FMU3Slave

    directory = Path(directory)
    root = directory / name
    if root.exists():
        shutil.rmtree(root)
    (root / "sources").mkdir(parents=True)
    bindir = root / "binaries" / platform_tuple
    bindir.mkdir(parents=True)
    stubs = "".join(
        f"int {n}(void) {{ return 3; }}\n"
        for n in sorted(dir(FMU3Slave))
        if n.startswith("fmi3") and n not in _FMI3_DONE
    )
    src = root / "sources" / "tiny3.c"
    src.write_text(C3_SOURCE + stubs)
    subprocess.run(
        [
            "gcc",
            "-shared",
            "-fPIC",
            "-O1",
            "-w",
            f"-DI1V={I1}",
            f"-DI3V={I3}",
            str(src),
            "-o",
            str(bindir / "tiny3.so"),
            "-lm",
        ],
        check=True,
    )
    (root / "modelDescription.xml").write_text(_xml3(interface, flags))
    out = directory / f"{name}.fmu"
    with zipfile.ZipFile(out, "w") as zf:
        for p in sorted(root.rglob("*")):
            if p.is_file():
                zf.write(p, p.relative_to(root).as_posix())
    out.with_suffix(".toml").write_text(MAPPING)
    return out
