/*
 * postcapture FMU: the FMI 2.0 co-simulation interface around the compiled plant core.
 *
 * The plant is the core of postcapture.dynamics (dynamics/csrc, compiled into this library with the
 * model's packed arrays from the generated pc_fmu_data.h): the same integrator, Newton policy, warm
 * start, step rule, outputs and Jacobians as the native process model.
 *
 * State correction (the standard forbids fmi2SetReal on states after initialisation): set the inputs
 * x_corr[...] and reset = 1; at the start of the next fmi2DoStep the state is replaced by x_corr (its
 * quaternion checked and normalised). Step Jacobian: set jacobian_request = 1; after fmi2DoStep the
 * outputs F, g, H, h hold the exact derivatives of that communication step (NaN otherwise).
 *
 * Calls are checked: every real must be finite and within PC_MAX_ABS, a communication step finite,
 * positive, a whole multiple of the internal step and at most PC_MAX_COMM_STEP; a failing call returns
 * fmi2Error with a logged message naming the variable, keeps the state, and a failed step puts the
 * instance in the error state (only getters, fmi2SetFMUstate, fmi2Reset, fmi2Terminate and
 * fmi2FreeInstance are then accepted).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "pc_fmu_data.h"
#include "pc_plant.h"

#define NQ PC_NQ
#define NV PC_NV
#define NX (PC_NQ + PC_NV)
#define NT (2 * PC_NV)
#define NPF (PC_NP + 1) /* FMU parameters: target_mass, then the plant's parameter vector */
#define PC_MAX_ABS 1e15   /* largest magnitude of any real set through fmi2SetReal */
#define PC_QUAT_TOL 1e-6  /* |norm(quaternion) - 1| accepted in x_corr before normalisation */
#if PC_STEP_JACOBIAN
#define PC_NJAC (NT * NT + NT + PC_NZ * NT + PC_NZ)
#else
#define PC_NJAC 1
#endif

enum { MODE_INSTANTIATED = 0, MODE_INIT = 1, MODE_STEP = 2, MODE_TERMINATED = 3, MODE_ERROR = 4 };

/* Everything fmi2GetFMUstate saves: plain data, copied and serialised byte for byte. */
typedef struct {
    double time, last_ok_time;
    double x[NX];
    double p[PC_NP > 0 ? PC_NP : 1];
    double u[PC_NU];
    double xc[NX];
    double reset, jreq;
    double jac[PC_NJAC];
    int jac_valid, mode;
} pc_fmu_state_t;

typedef struct {
    pc_fmu_state_t c;
    pc_model_t* m;
    pc_data_t* d;
    char* name;
    fmi2CallbackFunctions cb;
    int logging, out_valid;
    double y[PC_NY], xdot[NX], ddq[NV];
    char last_error[512];
} pc_fmu_t;

#define PC_STATE_MAGIC 0x53464350u /* "PCFS" */
#define PC_STATE_VERSION 2u

static void logf_(pc_fmu_t* F, fmi2Status status, const char* category, const char* fmt, ...) {
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (status == fmi2Error) snprintf(F->last_error, sizeof F->last_error, "%s", buf);
    if (!F->cb.logger || (status == fmi2OK && !F->logging)) return;
    F->cb.logger(F->cb.componentEnvironment, F->name, status, category, "%s", buf);
}

static fmi2Status fail(pc_fmu_t* F, const char* function, const char* fmt, ...) {
    char buf[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    logf_(F, fmi2Error, "logStatusError", "%s: %s", function, buf);
    return fmi2Error;
}

static fmi2Status in_error(pc_fmu_t* F, const char* function) {
    if (F->c.mode != MODE_ERROR) return fmi2OK;
    if (F->cb.logger)
        F->cb.logger(F->cb.componentEnvironment, F->name, fmi2Error, "logStatusError",
                     "%s: the instance is in the error state after: %s (use fmi2SetFMUstate or fmi2Reset)", function,
                     F->last_error);
    return fmi2Error;
}

static uint32_t guid_hash(void) {
    const char* s = PC_GUID;
    uint32_t h = 2166136261u;
    while (*s) { h ^= (uint8_t)*s++; h *= 16777619u; }
    return h;
}

/* d p / d m: the hub's mass at a fixed centre of mass and inertia about it (T-frame parameters). */
static void mass_direction(const double* p, double* d) {
    int i;
    for (i = 0; i < PC_NP; i++) d[i] = 0.0;
#if PC_HAS_TARGET
    {
        double c[3] = {p[1] / p[0], p[2] / p[0], p[3] / p[0]}, cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        d[0] = 1.0; d[1] = c[0]; d[2] = c[1]; d[3] = c[2];
        d[4] = cc - c[0] * c[0]; d[5] = -c[0] * c[1]; d[6] = cc - c[1] * c[1];
        d[7] = -c[0] * c[2]; d[8] = -c[1] * c[2]; d[9] = cc - c[2] * c[2];
    }
#endif
}

static void defaults(pc_fmu_t* F) {
    int i;
    memset(&F->c, 0, sizeof F->c);
    memcpy(F->c.x, PC_X0, sizeof F->c.x);
    memcpy(F->c.xc, PC_X0, sizeof F->c.xc);
    for (i = 0; i < PC_NP; i++) F->c.p[i] = PC_P0[i];
    for (i = 0; i < PC_NJAC; i++) F->c.jac[i] = NAN;
    F->out_valid = 0;
}

static void push_settings(pc_fmu_t* F) {
    if (PC_NP) pc_set_params(F->m, F->d, F->c.p);
    pc_set_input_offset(F->m, F->d, F->c.u);
}

/* ------------------------------------------------------------------------------------ outputs */
static int update_outputs(pc_fmu_t* F) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    double mech[11 + PC_NZ], panels[4 * PC_NPANELS + 1], R[9];
    int i, k = 0, off = NQ - NV;
    if (F->out_valid) return 0;
    push_settings(F);
    if (pc_sample(F->m, F->d, q, v, F->c.time, F->ddq, panels, mech)) return 1;
    /* y: q_BN (w >= 0) 4, omega 3, r 3, accel 3, arm q, dq, ddq, panels (tip 3, torsion) */
    {
        double s = q[6] < 0.0 ? -1.0 : 1.0;
        F->y[k++] = s * q[6]; F->y[k++] = s * q[3]; F->y[k++] = s * q[4]; F->y[k++] = s * q[5];
    }
    for (i = 0; i < 3; i++) F->y[k++] = v[3 + i];
    for (i = 0; i < 3; i++) F->y[k++] = q[i];
    for (i = 0; i < 3; i++) F->y[k++] = mech[11 + i];
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? q[PC_ARM_V[i] + off] : 0.0;
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? v[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? F->ddq[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < 4 * PC_NPANELS; i++) F->y[k++] = panels[i];
    /* ambient state derivative: dp/dt = R v, dquat/dt = quat (w, 0) / 2, de/dt = v_e, dv/dt = ddq */
    {
        const double* a = q + 3;
        const double* w = v + 3;
        double Rv[3];
        /* rotation of the (x, y, z, w) quaternion, Eigen's formula */
        double x = a[0], y = a[1], z = a[2], ww = a[3];
        R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - ww * z); R[2] = 2 * (x * z + ww * y);
        R[3] = 2 * (x * y + ww * z); R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - ww * x);
        R[6] = 2 * (x * z - ww * y); R[7] = 2 * (y * z + ww * x); R[8] = 1 - 2 * (x * x + y * y);
        for (i = 0; i < 3; i++) Rv[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
        for (i = 0; i < 3; i++) F->xdot[i] = Rv[i];
        F->xdot[3] = 0.5 * (a[3] * w[0] + a[1] * w[2] - a[2] * w[1]);
        F->xdot[4] = 0.5 * (a[3] * w[1] - a[0] * w[2] + a[2] * w[0]);
        F->xdot[5] = 0.5 * (a[3] * w[2] + a[0] * w[1] - a[1] * w[0]);
        F->xdot[6] = 0.5 * (-a[0] * w[0] - a[1] * w[1] - a[2] * w[2]);
    }
    for (i = 7; i < NQ; i++) F->xdot[i] = v[i - 1];
    for (i = 0; i < NV; i++) F->xdot[NQ + i] = F->ddq[i];
    F->out_valid = 1;
    return 0;
}

/* ------------------------------------------------------------------------------------ lifecycle */
FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    ((pc_fmu_t*)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    pc_fmu_t* F;
    char err[512] = "";
    (void)resourceLocation; (void)visible;
    if (!functions || !instanceName) return NULL;
    if (fmuType != fmi2CoSimulation) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: this FMU supports co-simulation only");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, PC_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: GUID %s does not match the binary's %s", fmuGUID ? fmuGUID : "(null)",
                              PC_GUID);
        return NULL;
    }
    F = (pc_fmu_t*)calloc(1, sizeof(pc_fmu_t));
    if (!F) return NULL;
    F->name = (char*)malloc(strlen(instanceName) + 1);
    F->m = pc_model_create(PC_IB, PC_DB, sizeof PC_IB / sizeof PC_IB[0], sizeof PC_DB / sizeof PC_DB[0], PC_STAGES,
                           &PC_TAB_A[0][0], PC_TAB_B, PC_TAB_C, err, sizeof err);
    F->d = F->m ? pc_data_create(F->m) : NULL;
    if (!F->name || !F->m || !F->d) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: the plant could not be created: %s", F->m ? "out of memory" : err);
        pc_data_destroy(F->d);
        pc_model_destroy(F->m);
        free(F->name);
        free(F);
        return NULL;
    }
    strcpy(F->name, instanceName);
    F->cb = *functions;
    F->logging = loggingOn ? 1 : 0;
    defaults(F);
    F->c.mode = MODE_INSTANTIATED;
    return F;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (!F) return;
    pc_data_destroy(F->d);
    pc_model_destroy(F->m);
    free(F->name);
    free(F);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (F->c.mode != MODE_INSTANTIATED) return fail(F, "fmi2SetupExperiment", "only allowed after fmi2Instantiate");
    if (!(fabs(startTime) < PC_MAX_ABS)) return fail(F, "fmi2SetupExperiment", "startTime %.17g is not a finite time", startTime);
    F->c.time = F->c.last_ok_time = startTime;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (F->c.mode != MODE_INSTANTIATED) return fail(F, "fmi2EnterInitializationMode", "wrong state");
    F->c.mode = MODE_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (F->c.mode != MODE_INIT) return fail(F, "fmi2ExitInitializationMode", "wrong state");
    F->c.mode = MODE_STEP;
    F->out_valid = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    ((pc_fmu_t*)c)->c.mode = MODE_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    defaults(F);
    F->c.mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ values */
FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    size_t k;
    for (k = 0; k < nvr; k++) {
        fmi2ValueReference r = vr[k];
        if (r < PC_VR_DX) value[k] = F->c.x[r - PC_VR_X];
        else if (r < PC_VR_Y) {
            if (update_outputs(F)) return fail(F, "fmi2GetReal", "output evaluation failed: %s", pc_error_message(F->d));
            value[k] = F->xdot[r - PC_VR_DX];
        } else if (r < PC_VR_P) {
            if (update_outputs(F)) return fail(F, "fmi2GetReal", "output evaluation failed: %s", pc_error_message(F->d));
            value[k] = F->y[r - PC_VR_Y];
        } else if (r == PC_VR_P) value[k] = (PC_HAS_TARGET ? F->c.p[0] : 0.0) + PC_TARGET_PANEL_MASS;
        else if (r < PC_VR_U) value[k] = F->c.p[r - PC_VR_P - 1];
        else if (r < PC_VR_XC) value[k] = F->c.u[r - PC_VR_U];
        else if (r < PC_VR_RESET) value[k] = F->c.xc[r - PC_VR_XC];
        else if (r == PC_VR_RESET) value[k] = F->c.reset;
        else if (r == PC_VR_JREQ) value[k] = F->c.jreq;
#if PC_STEP_JACOBIAN
        else if (r >= PC_VR_JAC && r < PC_VR_JAC + PC_NJAC) value[k] = F->c.jac[r - PC_VR_JAC];
#endif
        else return fail(F, "fmi2GetReal", "unknown value reference %u", (unsigned)r);
    }
    return fmi2OK;
}

static const char* vr_name(fmi2ValueReference r) {
    return r < PC_NVARS ? PC_VAR_NAMES[r] : "?";
}

/* the target mass sets the hub's mass at a fixed centre of mass and inertia about it */
static fmi2Status set_target_mass(pc_fmu_t* F, pc_fmu_state_t* next, double x) {
#if PC_HAS_TARGET
    double d[PC_NP > 0 ? PC_NP : 1], m_hub = x - PC_TARGET_PANEL_MASS, dm;
    int i;
    if (!(m_hub > 0.0))
        return fail(F, "fmi2SetReal", "target_mass = %.17g: expected more than the panels' %.17g kg", x,
                    PC_TARGET_PANEL_MASS);
    mass_direction(next->p, d);
    dm = m_hub - next->p[0];
    for (i = 0; i < PC_NP; i++) next->p[i] += dm * d[i];
    next->p[0] = m_hub;
    return fmi2OK;
#else
    (void)next; (void)x;
    return fail(F, "fmi2SetReal", "target_mass: this plant has no target");
#endif
}

/* one value into the next state (all or nothing: the caller commits only if every one is valid) */
static fmi2Status set_one(pc_fmu_t* F, pc_fmu_state_t* next, fmi2ValueReference r, double x) {
    if (!(fabs(x) <= PC_MAX_ABS))
        return fail(F, "fmi2SetReal", "%s = %.17g: expected a finite number of magnitude at most %g", vr_name(r), x,
                    PC_MAX_ABS);
    if (r < PC_VR_DX) {
        if (F->c.mode != MODE_INSTANTIATED && F->c.mode != MODE_INIT)
            return fail(F, "fmi2SetReal",
                        "%s: a state can only be set before fmi2ExitInitializationMode; correct it with the "
                        "x_corr inputs and reset = 1 (applied at the start of fmi2DoStep)", vr_name(r));
        next->x[r - PC_VR_X] = x;
        next->xc[r - PC_VR_X] = x;
    } else if (r == PC_VR_P) {
        return set_target_mass(F, next, x);
    } else if (r > PC_VR_P && r < PC_VR_U) {
        int i = (int)(r - PC_VR_P - 1);
        if (!(x >= PC_P_MIN[i])) return fail(F, "fmi2SetReal", "%s = %.17g: expected at least %.17g", vr_name(r), x, PC_P_MIN[i]);
        next->p[i] = x;
    } else if (r >= PC_VR_U && r < PC_VR_XC) next->u[r - PC_VR_U] = x;
    else if (r >= PC_VR_XC && r < PC_VR_RESET) next->xc[r - PC_VR_XC] = x;
    else if (r == PC_VR_RESET) next->reset = x;
    else if (r == PC_VR_JREQ) next->jreq = x;
    else return fail(F, "fmi2SetReal", "%s is not settable (an output or an unknown value reference)", vr_name(r));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    pc_fmu_state_t next;
    size_t k;
    if (in_error(F, "fmi2SetReal")) return fmi2Error;
    if (F->c.mode == MODE_TERMINATED) return fail(F, "fmi2SetReal", "the instance is terminated");
    next = F->c; /* all or nothing: the values go in only if every one is valid */
    for (k = 0; k < nvr; k++)
        if (set_one(F, &next, vr[k], value[k]) != fmi2OK) return fmi2Error;
    if (PC_NP && memcmp(next.p, F->c.p, sizeof next.p) != 0 && pc_set_params(F->m, F->d, next.p)) {
        pc_set_params(F->m, F->d, F->c.p);
        return fail(F, "fmi2SetReal", "parameters refused: %s", pc_error_message(F->d));
    }
    F->c = next;
    F->out_valid = 0;
    return fmi2OK;
}

#define PC_NO_VARIABLES(fn, type)                                                                   \
    FMI2_Export fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[]) { \
        (void)vr; (void)value;                                                                      \
        return nvr ? fail((pc_fmu_t*)c, #fn, "this FMU has Real variables only") : fmi2OK;          \
    }
PC_NO_VARIABLES(fmi2GetInteger, fmi2Integer)
PC_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean)
PC_NO_VARIABLES(fmi2GetString, fmi2String)
PC_NO_VARIABLES(fmi2SetInteger, const fmi2Integer)
PC_NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean)
PC_NO_VARIABLES(fmi2SetString, const fmi2String)

/* ------------------------------------------------------------------------------------ FMU state */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (!*state) *state = malloc(sizeof(pc_fmu_state_t));
    if (!*state) return fail(F, "fmi2GetFMUstate", "out of memory");
    memcpy(*state, &F->c, sizeof(pc_fmu_state_t));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (!state) return fail(F, "fmi2SetFMUstate", "null state");
    memcpy(&F->c, state, sizeof(pc_fmu_state_t));
    if (PC_NP) pc_set_params(F->m, F->d, F->c.p);
    F->out_valid = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state) {
    (void)c;
    if (state && *state) { free(*state); *state = NULL; }
    return fmi2OK;
}

#define PC_HEADER_SIZE (4 * sizeof(uint32_t))

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size) {
    (void)c; (void)state;
    *size = PC_HEADER_SIZE + sizeof(pc_fmu_state_t);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    uint32_t header[4] = {PC_STATE_MAGIC, PC_STATE_VERSION, (uint32_t)sizeof(pc_fmu_state_t), 0};
    header[3] = guid_hash();
    if (size < PC_HEADER_SIZE + sizeof(pc_fmu_state_t)) return fail((pc_fmu_t*)c, "fmi2SerializeFMUstate", "buffer too small");
    memcpy(bytes, header, PC_HEADER_SIZE);
    memcpy(bytes + PC_HEADER_SIZE, state, sizeof(pc_fmu_state_t));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    uint32_t header[4];
    if (size != PC_HEADER_SIZE + sizeof(pc_fmu_state_t)) return fail(F, "fmi2DeSerializeFMUstate", "wrong size");
    memcpy(header, bytes, PC_HEADER_SIZE);
    if (header[0] != PC_STATE_MAGIC || header[1] != PC_STATE_VERSION || header[2] != sizeof(pc_fmu_state_t) ||
        header[3] != guid_hash())
        return fail(F, "fmi2DeSerializeFMUstate", "not a state of this FMU");
    if (!*state) *state = malloc(sizeof(pc_fmu_state_t));
    if (!*state) return fail(F, "fmi2DeSerializeFMUstate", "out of memory");
    memcpy(*state, bytes + PC_HEADER_SIZE, sizeof(pc_fmu_state_t));
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ derivatives */
#if PC_DIRECTIONAL
/* Continuous partials of the ambient state derivative and of the named outputs for an ambient state
 * direction dx and an input direction du, exact (the core's partials, the outputs' kinematics). */
/* d(ambient state derivative) for dx (ambient), dv and the acceleration change dd */
static void directional_xdot(const double* q, const double* v, const double* dx, const double* dd, double* dxdot) {
    const double* dv = dx + NQ;
    const double* a = q + 3;
    const double* da = dx + 3;
    const double* w = v + 3;
    const double* dw = dv + 3;
    double x = a[0], y = a[1], z = a[2], ww = a[3], dxq = da[0], dyq = da[1], dzq = da[2], dwq = da[3];
    double R[9], dR[9];
    int i;
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - ww * z); R[2] = 2 * (x * z + ww * y);
    R[3] = 2 * (x * y + ww * z); R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - ww * x);
    R[6] = 2 * (x * z - ww * y); R[7] = 2 * (y * z + ww * x); R[8] = 1 - 2 * (x * x + y * y);
    dR[0] = -4 * (y * dyq + z * dzq); dR[1] = 2 * (x * dyq + y * dxq - ww * dzq - z * dwq);
    dR[2] = 2 * (x * dzq + z * dxq + ww * dyq + y * dwq); dR[3] = 2 * (x * dyq + y * dxq + ww * dzq + z * dwq);
    dR[4] = -4 * (x * dxq + z * dzq); dR[5] = 2 * (y * dzq + z * dyq - ww * dxq - x * dwq);
    dR[6] = 2 * (x * dzq + z * dxq - ww * dyq - y * dwq); dR[7] = 2 * (y * dzq + z * dyq + ww * dxq + x * dwq);
    dR[8] = -4 * (x * dxq + y * dyq);
    for (i = 0; i < 3; i++)
        dxdot[i] = dR[3 * i] * v[0] + dR[3 * i + 1] * v[1] + dR[3 * i + 2] * v[2] + R[3 * i] * dv[0] +
                   R[3 * i + 1] * dv[1] + R[3 * i + 2] * dv[2];
    dxdot[3] = 0.5 * (da[3] * w[0] + da[1] * w[2] - da[2] * w[1] + a[3] * dw[0] + a[1] * dw[2] - a[2] * dw[1]);
    dxdot[4] = 0.5 * (da[3] * w[1] - da[0] * w[2] + da[2] * w[0] + a[3] * dw[1] - a[0] * dw[2] + a[2] * dw[0]);
    dxdot[5] = 0.5 * (da[3] * w[2] + da[0] * w[1] - da[1] * w[0] + a[3] * dw[2] + a[0] * dw[1] - a[1] * dw[0]);
    dxdot[6] = 0.5 * (-da[0] * w[0] - da[1] * w[1] - da[2] * w[2] - a[0] * dw[0] - a[1] * dw[1] - a[2] * dw[2]);
    for (i = 7; i < NQ; i++) dxdot[i] = dv[i - 1];
    for (i = 0; i < NV; i++) dxdot[NQ + i] = dd[i];
}

/* d(accel_B) = d(ddq[0:3] + w x v + dw x r + w x (w x r)) */
static void directional_accel(const double* v, const double* dv, const double* dd, double* out) {
    const double* w = v + 3;
    const double* dw = dv + 3;
    const double* ddw = dd + 3;
    const double* r = PC_R_ACC;
    double a1[3], a2[3], a3[3], wr[3], dwr[3], t1[3], t2[3];
    int i;
#define CROSS(a_, b_, o_) do { o_[0] = a_[1] * b_[2] - a_[2] * b_[1]; o_[1] = a_[2] * b_[0] - a_[0] * b_[2]; o_[2] = a_[0] * b_[1] - a_[1] * b_[0]; } while (0)
    CROSS(dw, v, a1); CROSS(w, dv, a2); CROSS(ddw, r, a3);
    CROSS(w, r, wr); CROSS(dw, r, dwr); CROSS(dw, wr, t1); CROSS(w, dwr, t2);
#undef CROSS
    for (i = 0; i < 3; i++) out[i] = dd[i] + a1[i] + a2[i] + a3[i] + t1[i] + t2[i];
}

/* d(named outputs), in update_outputs' order */
static int directional_outputs(pc_fmu_t* F, const double* dx, const double* dd, double* dy) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    const double* dv = dx + NQ;
    double Jp[4 * PC_NPANELS * NV + 1], Jq[16 * PC_NPANELS + 1], s = q[6] < 0.0 ? -1.0 : 1.0;
    int i, j, k = 0, off = NQ - NV;
    dy[k++] = s * dx[6]; dy[k++] = s * dx[3]; dy[k++] = s * dx[4]; dy[k++] = s * dx[5];
    for (i = 0; i < 3; i++) dy[k++] = dv[3 + i];
    for (i = 0; i < 3; i++) dy[k++] = dx[i];
    directional_accel(v, dv, dd, dy + k);
    k += 3;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dx[PC_ARM_V[i] + off] : 0.0;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dv[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dd[PC_ARM_V[i]] : 0.0;
    if (pc_panel_jacobian(F->m, F->d, q, Jp) || pc_panel_quat_jacobian(F->m, F->d, q, Jq)) return 1;
    for (i = 0; i < 4 * PC_NPANELS; i++) {
        double t = 0.0;
        for (j = 6; j < NV; j++) t += Jp[i * NV + j] * dx[j + off];
        for (j = 0; j < 4; j++) t += Jq[i * 4 + j] * dx[3 + j];
        dy[k++] = t;
    }
    return 0;
}

/* Continuous partials of the ambient state derivative and of the named outputs for an ambient state
 * direction dx and an input direction du, exact (the core's partials, the outputs' kinematics). */
static int directional(pc_fmu_t* F, const double* dx, const double* du, double* dxdot, double* dy) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    const double* dv = dx + NQ;
    double u[PC_NU], dd[NV];
    double* Aq = (double*)malloc((2 * (size_t)NV * NV + (size_t)NV * PC_NU) * sizeof(double));
    double *Av, *Au;
    int i, j, off = NQ - NV, err;
    if (!Aq) return 1;
    Av = Aq + NV * NV; Au = Av + NV * NV;
    F->out_valid = 0;
    err = update_outputs(F);
    if (!err) err = pc_inputs(F->m, F->d, F->c.time, 0, u) || pc_derivatives(F->m, F->d, q, v, u, NULL, Aq, Av, Au, NULL);
    for (i = 0; i < NV && !err; i++) {
        double s = 0.0;
        for (j = 6; j < NV; j++) s += Aq[i * NV + j] * dx[j + off]; /* no gravity: the root pose does not enter */
        for (j = 0; j < NV; j++) s += Av[i * NV + j] * dv[j];
        for (j = 0; j < PC_NU; j++) s += Au[i * PC_NU + j] * du[j];
        dd[i] = s;
    }
    free(Aq);
    if (err) return 1;
    directional_xdot(q, v, dx, dd, dxdot);
    return directional_outputs(F, dx, dd, dy);
}
#endif

FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    pc_fmu_t* F = (pc_fmu_t*)c;
#if PC_DIRECTIONAL
    double dx[NX], du[PC_NU], dxdot[NX], dy[PC_NY];
    size_t k;
    if (in_error(F, "fmi2GetDirectionalDerivative")) return fmi2Error;
    memset(dx, 0, sizeof dx);
    memset(du, 0, sizeof du);
    for (k = 0; k < nKnown; k++) {
        fmi2ValueReference r = vKnown_ref[k];
        if (!(fabs(dvKnown[k]) <= PC_MAX_ABS))
            return fail(F, "fmi2GetDirectionalDerivative", "seed of %s is not finite", vr_name(r));
        if (r < PC_VR_DX) dx[r - PC_VR_X] += dvKnown[k];
        else if (r >= PC_VR_U && r < PC_VR_XC) du[r - PC_VR_U] += dvKnown[k];
        else return fail(F, "fmi2GetDirectionalDerivative", "a known must be a state or an input (force, torque, joint)");
    }
    if (directional(F, dx, du, dxdot, dy))
        return fail(F, "fmi2GetDirectionalDerivative", "evaluation failed: %s", pc_error_message(F->d));
    for (k = 0; k < nUnknown; k++) {
        fmi2ValueReference r = vUnknown_ref[k];
        if (r < PC_VR_DX) dvUnknown[k] = dx[r - PC_VR_X];
        else if (r < PC_VR_Y) dvUnknown[k] = dxdot[r - PC_VR_DX];
        else if (r < PC_VR_P) dvUnknown[k] = dy[r - PC_VR_Y];
#if PC_STEP_JACOBIAN
        else if (r >= PC_VR_JAC && r < PC_VR_JAC + PC_NJAC) dvUnknown[k] = 0.0;
#endif
        else return fail(F, "fmi2GetDirectionalDerivative", "an unknown must be a state derivative or an output");
    }
    return fmi2OK;
#else
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return fail(F, "fmi2GetDirectionalDerivative", "this FMU was exported without directional derivatives");
#endif
}

/* ------------------------------------------------------------------------------------ co-simulation */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? fail((pc_fmu_t*)c, "fmi2SetRealInputDerivatives", "inputs are held constant over a step") : fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? fail((pc_fmu_t*)c, "fmi2GetRealOutputDerivatives", "output derivatives are not provided") : fmi2OK;
}

/* the step's arguments: a finite time, a step in (0, PC_MAX_COMM_STEP], a whole number n of internal steps */
static fmi2Status check_step(pc_fmu_t* F, double t, double H, long* n) {
    if (in_error(F, "fmi2DoStep")) return fmi2Error;
    if (F->c.mode != MODE_STEP) return fail(F, "fmi2DoStep", "not in step mode (call fmi2ExitInitializationMode first)");
    if (!(H > 0.0) || !(H <= PC_MAX_COMM_STEP))
        return fail(F, "fmi2DoStep", "communicationStepSize = %.17g: expected a finite step in (0, %g] s", H,
                    (double)PC_MAX_COMM_STEP);
    if (!(fabs(t) < PC_MAX_ABS)) return fail(F, "fmi2DoStep", "currentCommunicationPoint = %.17g is not finite", t);
    *n = (long)floor(H / PC_STEP + 0.5);
    if (*n < 1 || fabs(*n * PC_STEP - H) > 1e-9 * H)
        return fail(F, "fmi2DoStep", "communicationStepSize = %.17g: expected a whole multiple of the internal step %.17g s",
                    H, (double)PC_STEP);
    return fmi2OK;
}

/* the state the step starts from: the current one, or x_corr (its quaternion checked and normalised) */
static fmi2Status start_state(pc_fmu_t* F, double* x) {
    double nq2 = 0.0, s;
    int i;
    memcpy(x, F->c.x, sizeof(double) * NX);
    if (!(F->c.reset > 0.5)) return fmi2OK;
    for (i = 3; i < 7; i++) nq2 += F->c.xc[i] * F->c.xc[i];
    if (!(fabs(sqrt(nq2) - 1.0) <= PC_QUAT_TOL))
        return fail(F, "fmi2DoStep", "x_corr[4..7] (the attitude quaternion) has norm %.17g: expected 1 within %g",
                    sqrt(nq2), PC_QUAT_TOL);
    memcpy(x, F->c.xc, sizeof(double) * NX);
    s = 1.0 / sqrt(nq2);
    for (i = 3; i < 7; i++) x[i] *= s;
    return fmi2OK;
}

#if PC_STEP_JACOBIAN
/* the Jacobian outputs F, g, H, h from the prediction's F, G (parameters), H, Hp and d p / d m */
static void store_jacobians(pc_fmu_t* F, const double* Fx, const double* G, const double* Hm, const double* Hp) {
    double* J = F->c.jac;
    double d[PC_NP > 0 ? PC_NP : 1];
    int r, k;
    mass_direction(F->c.p, d);
    memcpy(J, Fx, (size_t)NT * NT * sizeof(double));
    for (r = 0; r < NT; r++) {
        double s = 0.0;
        for (k = 0; k < PC_NP; k++) s += G[r * PC_NP + k] * d[k];
        J[NT * NT + r] = PC_HAS_TARGET ? s : 0.0;
    }
    memcpy(J + NT * NT + NT, Hm, (size_t)PC_NZ * NT * sizeof(double));
    for (r = 0; r < PC_NZ; r++) {
        double s = 0.0;
        for (k = 0; k < PC_NP; k++) s += Hp[r * PC_NP + k] * d[k];
        J[NT * NT + NT + PC_NZ * NT + r] = PC_HAS_TARGET ? s : 0.0;
    }
    F->c.jac_valid = 1;
}
#endif

/* n internal steps from x at t (and the Jacobian outputs when requested); 1 on failure */
static int advance(pc_fmu_t* F, double* x, double t, long n, int want_jac) {
    double z[PC_NZ];
    int i, err;
#if PC_STEP_JACOBIAN
    double *Fx = NULL, *G = NULL, *Hm = NULL, *Hp = NULL;
    if (want_jac) {
        Fx = (double*)malloc(((size_t)NT * NT + (size_t)NT * (PC_NP + PC_NU + 1) + (size_t)PC_NZ * NT +
                              (size_t)PC_NZ * (PC_NP + PC_NU + 1)) * sizeof(double));
        if (!Fx) return 1;
        G = Fx + NT * NT; Hm = G + NT * (PC_NP + 1); Hp = Hm + PC_NZ * NT;
    }
    err = pc_predict(F->m, F->d, x, x + NQ, t, PC_STEP, (int)n, want_jac, z, Fx, NULL, G, Hm, NULL, Hp);
    if (!err && want_jac) store_jacobians(F, Fx, G, Hm, Hp);
    free(Fx);
#else
    err = pc_predict(F->m, F->d, x, x + NQ, t, PC_STEP, (int)n, 0, z, NULL, NULL, NULL, NULL, NULL, NULL);
#endif
    if (!err && !want_jac) {
        for (i = 0; i < PC_NJAC; i++) F->c.jac[i] = NAN;
        F->c.jac_valid = 0;
    }
    return err;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    double x[NX], H = communicationStepSize, t = currentCommunicationPoint;
    long n;
    int want_jac = PC_STEP_JACOBIAN && F->c.jreq > 0.5;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (check_step(F, t, H, &n) != fmi2OK || start_state(F, x) != fmi2OK) return fmi2Error;
    push_settings(F);
    if (advance(F, x, t, n, want_jac)) {
        F->c.mode = MODE_ERROR;
        return fail(F, "fmi2DoStep", "the step from t = %.17g s failed: %s", t, pc_error_message(F->d));
    }
    memcpy(F->c.x, x, sizeof x);
    F->c.time = t + H;
    F->c.last_ok_time = F->c.time;
    F->out_valid = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    return fail((pc_fmu_t*)c, "fmi2CancelStep", "steps are synchronous");
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
    pc_fmu_t* F = (pc_fmu_t*)c;
    if (s != fmi2DoStepStatus) return fmi2Discard;
    *value = F->c.mode == MODE_ERROR ? fmi2Error : fmi2OK;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = ((pc_fmu_t*)c)->c.last_ok_time;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}

FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
    (void)c;
    if (s != fmi2Terminated) return fmi2Discard;
    *value = fmi2False;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}
