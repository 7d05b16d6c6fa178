/*
 * postcapture estimator FMU: the FMI 2.0 co-simulation interface of pc_estimator.c. One fmi2DoStep is one
 * filter cycle: the predictor inside (the engine's plant and exact Jacobians), then the corrector with the
 * inputs set for that step. A step other than the filter's period returns fmi2Error with a logged message;
 * fmi2SetFMUstate and fmi2DeSerializeFMUstate refuse a state whose quaternions are not unit or whose
 * covariance is not finite and symmetric. A failed step puts the instance in the error state (getters,
 * fmi2SetFMUstate, fmi2Reset, fmi2Terminate and fmi2FreeInstance still work).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "pc_estimator.h"

enum { MODE_INSTANTIATED = 0, MODE_INIT = 1, MODE_STEP = 2, MODE_TERMINATED = 3, MODE_ERROR = 4 };

typedef struct {
    pc_est_t E;
    char* name;
    fmi2CallbackFunctions cb;
    int logging, mode;
    double t0, last_ok;
} est_fmu_t;

typedef struct {
    uint32_t magic, size;
    int mode;
    double last_ok;
    double data[1]; /* pc_est_save */
} est_state_t;

#define EST_MAGIC 0x45534350u /* "PCSE" */

static fmi2Status fail(est_fmu_t* F, const char* function, const char* fmt, ...) {
    char buf[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (F->cb.logger) F->cb.logger(F->cb.componentEnvironment, F->name, fmi2Error, "logStatusError", "%s: %s", function, buf);
    return fmi2Error;
}

FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n, const fmi2String cat[]) {
    (void)n; (void)cat;
    ((est_fmu_t*)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    est_fmu_t* F;
    char err[512] = "";
    (void)resourceLocation; (void)visible;
    if (!functions || !instanceName) return NULL;
    if (fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, PCE_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: %s", fmuType != fmi2CoSimulation ? "co-simulation only"
                                                                                 : "the GUID does not match the binary's");
        return NULL;
    }
    F = (est_fmu_t*)calloc(1, sizeof(est_fmu_t));
    if (!F) return NULL;
    F->name = (char*)malloc(strlen(instanceName) + 1);
    if (!F->name || pc_est_create(&F->E, err, sizeof err)) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: the estimator could not be created: %s", err);
        free(F->name);
        free(F);
        return NULL;
    }
    strcpy(F->name, instanceName);
    F->cb = *functions;
    F->logging = loggingOn ? 1 : 0;
    F->mode = MODE_INSTANTIATED;
    return F;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    est_fmu_t* F = (est_fmu_t*)c;
    if (!F) return;
    pc_est_destroy(&F->E);
    free(F->name);
    free(F);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real startTime,
                                           fmi2Boolean stopDefined, fmi2Real stopTime) {
    est_fmu_t* F = (est_fmu_t*)c;
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stopTime;
    if (F->mode != MODE_INSTANTIATED) return fail(F, "fmi2SetupExperiment", "only allowed after fmi2Instantiate");
    if (!(fabs(startTime) < 1e15)) return fail(F, "fmi2SetupExperiment", "startTime %g is not a finite time", startTime);
    F->t0 = F->last_ok = startTime;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    est_fmu_t* F = (est_fmu_t*)c;
    if (F->mode != MODE_INSTANTIATED) return fail(F, "fmi2EnterInitializationMode", "wrong state");
    F->mode = MODE_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    est_fmu_t* F = (est_fmu_t*)c;
    if (F->mode != MODE_INIT) return fail(F, "fmi2ExitInitializationMode", "wrong state");
    if (pc_est_start(&F->E, F->t0)) return fail(F, "fmi2ExitInitializationMode", "%s", F->E.message);
    F->mode = MODE_STEP;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    ((est_fmu_t*)c)->mode = MODE_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    est_fmu_t* F = (est_fmu_t*)c;
    pc_est_defaults(&F->E);
    F->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ values */
FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    est_fmu_t* F = (est_fmu_t*)c;
    size_t k;
    for (k = 0; k < nvr; k++) {
        if (vr[k] >= PCE_NREAL) return fail(F, "fmi2GetReal", "unknown value reference %u", (unsigned)vr[k]);
        value[k] = F->E.r[vr[k]];
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    est_fmu_t* F = (est_fmu_t*)c;
    size_t k;
    int retune = 0;
    if (F->mode == MODE_ERROR || F->mode == MODE_TERMINATED) return fail(F, "fmi2SetReal", "wrong state");
    for (k = 0; k < nvr; k++) { /* check all first: a refused call changes nothing */
        fmi2ValueReference r = vr[k];
        if (r >= PCE_NREAL || PCE_CAUSALITY[r] == 2)
            return fail(F, "fmi2SetReal", "value reference %u is not an input or a parameter", (unsigned)r);
        if (PCE_CAUSALITY[r] == 1 && F->mode == MODE_STEP && !PCE_TUNABLE[r])
            return fail(F, "fmi2SetReal", "%s is fixed after initialisation", PCE_NAMES[r]);
        if (PCE_CAUSALITY[r] == 1 && !(fabs(value[k]) < INFINITY))
            return fail(F, "fmi2SetReal", "%s = %g: expected a finite number", PCE_NAMES[r], value[k]);
        if (PCE_CAUSALITY[r] == 1 && PCE_POSITIVE[r] && !(value[k] >= 0.0))
            return fail(F, "fmi2SetReal", "%s = %g: expected a number >= 0", PCE_NAMES[r], value[k]);
    }
    for (k = 0; k < nvr; k++) {
        F->E.r[vr[k]] = value[k]; /* a non-finite input is a missing measurement (counted at the step) */
        retune |= PCE_CAUSALITY[vr[k]] == 1;
    }
    if (retune && F->mode == MODE_STEP) pc_est_retune(&F->E);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2GetInteger", "this FMU has no integer variables") : fmi2OK;
}
FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2SetInteger", "this FMU has no integer variables") : fmi2OK;
}
FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2GetBoolean", "this FMU has no boolean variables") : fmi2OK;
}
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2SetBoolean", "this FMU has no boolean variables") : fmi2OK;
}
FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2GetString", "this FMU has no string variables") : fmi2OK;
}
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)vr; (void)v;
    return n ? fail((est_fmu_t*)c, "fmi2SetString", "this FMU has no string variables") : fmi2OK;
}

/* ------------------------------------------------------------------------------------ FMU state */
static size_t state_bytes(est_fmu_t* F) {
    return sizeof(est_state_t) + pc_est_state_size(&F->E) * sizeof(double);
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
    est_fmu_t* F = (est_fmu_t*)c;
    est_state_t* S;
    if (!F->E.started) return fail(F, "fmi2GetFMUstate", "only after initialisation");
    S = (est_state_t*)(*state ? *state : malloc(state_bytes(F)));
    if (!S) return fail(F, "fmi2GetFMUstate", "out of memory");
    S->magic = EST_MAGIC;
    S->size = (uint32_t)state_bytes(F);
    S->mode = F->mode;
    S->last_ok = F->last_ok;
    pc_est_save(&F->E, S->data);
    *state = S;
    return fmi2OK;
}

static fmi2Status set_state(est_fmu_t* F, const est_state_t* S, const char* function) {
    if (!F->E.started) return fail(F, function, "only after initialisation");
    if (!S || S->magic != EST_MAGIC || S->size != state_bytes(F))
        return fail(F, function, "not a state of this estimator");
    if (pc_est_load(&F->E, S->data)) return fail(F, function, "refused: %s", F->E.message);
    F->mode = S->mode == MODE_ERROR ? MODE_STEP : S->mode;
    F->last_ok = S->last_ok;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return set_state((est_fmu_t*)c, (const est_state_t*)state, "fmi2SetFMUstate");
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state) {
    (void)c;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size) {
    (void)state;
    *size = state_bytes((est_fmu_t*)c);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    est_fmu_t* F = (est_fmu_t*)c;
    if (!state || size != state_bytes(F)) return fail(F, "fmi2SerializeFMUstate", "wrong size %zu", size);
    memcpy(bytes, state, size);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                               fmi2FMUstate* state) {
    est_fmu_t* F = (est_fmu_t*)c;
    est_state_t* S;
    fmi2Status st;
    if (size != state_bytes(F)) return fail(F, "fmi2DeSerializeFMUstate", "%zu bytes: not a state of this estimator", size);
    S = (est_state_t*)malloc(size);
    if (!S) return fail(F, "fmi2DeSerializeFMUstate", "out of memory");
    memcpy(S, bytes, size);
    /* checked now, against a scratch copy of this instance's state, so that a bad state is refused here */
    {
        double* keep = (double*)malloc(pc_est_state_size(&F->E) * sizeof(double));
        if (!keep) {
            free(S);
            return fail(F, "fmi2DeSerializeFMUstate", "out of memory");
        }
        pc_est_save(&F->E, keep);
        st = set_state(F, S, "fmi2DeSerializeFMUstate");
        pc_est_load(&F->E, keep);
        free(keep);
    }
    if (st != fmi2OK) {
        free(S);
        return st;
    }
    *state = S;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz, const fmi2Real dv[],
                                                    fmi2Real dz[]) {
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return fail((est_fmu_t*)c, "fmi2GetDirectionalDerivative", "not provided by the estimator");
}

FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return fail((est_fmu_t*)c, "fmi2SetRealInputDerivatives", "not supported");
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return fail((est_fmu_t*)c, "fmi2GetRealOutputDerivatives", "not supported");
}

/* ------------------------------------------------------------------------------------ step */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    est_fmu_t* F = (est_fmu_t*)c;
    (void)noSetPrior;
    if (F->mode != MODE_STEP) return fail(F, "fmi2DoStep", F->mode == MODE_ERROR ? "the instance is in the error state" : "wrong state");
    if (!(fabs(h - PCE_DT) <= 1e-9 * PCE_DT))
        return fail(F, "fmi2DoStep", "communicationStepSize = %.17g: this estimator's step is its filter cycle, "
                    "%.17g s", h, PCE_DT);
    if (!(fabs(t - F->E.t) <= 1e-9 * (1.0 + fabs(t))))
        return fail(F, "fmi2DoStep", "currentCommunicationPoint = %.17g: the estimates are at %.17g s", t, F->E.t);
    if (pc_est_cycle(&F->E, F->E.t, PCE_DT)) {
        F->mode = MODE_ERROR;
        return fail(F, "fmi2DoStep", "the filter cycle at t = %.17g s failed: %s", t, F->E.message);
    }
    /* time never accumulates: the k-th cycle ends at t0 + k dt */
    F->E.t = F->t0 + (double)F->E.k * PCE_DT;
    F->last_ok = F->E.t;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    return fail((est_fmu_t*)c, "fmi2CancelStep", "steps are synchronous");
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
    (void)s;
    *value = ((est_fmu_t*)c)->mode == MODE_ERROR ? fmi2Error : fmi2OK;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = ((est_fmu_t*)c)->last_ok;
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
