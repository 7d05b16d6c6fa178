/*
 * postcapture FMU runtime: the FMI 2.0 co-simulation interface around pc_core.
 *
 * State correction (the standard forbids fmi2SetReal on states after initialisation): set the inputs
 * x_corr[...] and reset = 1; at the start of the next fmi2DoStep the state is replaced by x_corr.
 * Step Jacobian: set jacobian_request = 1; after fmi2DoStep the outputs F, g, H, h hold the exact
 * derivatives of that communication step (NaN otherwise).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "pc_core.h"

typedef struct {
    pc_inst_t core;
    char* name;
    fmi2CallbackFunctions cb;
    int logging;
} pc_fmi2_t;

#define PC_STATE_MAGIC 0x53464350u /* "PCFS" */
#define PC_STATE_VERSION 1u

static const char* status_name(int s) {
    static const char* names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
    return (s >= 0 && s <= 5) ? names[s] : "?";
}

static void log_trampoline(void* env, int status, const char* category, const char* message) {
    pc_fmi2_t* F = (pc_fmi2_t*)env;
    if (!F->cb.logger) return;
    if (status == PC_OK && !F->logging) return;
    F->cb.logger(F->cb.componentEnvironment, F->name, (fmi2Status)status, category, "%s", message);
}

static fmi2Status fail(pc_fmi2_t* F, const char* function, const char* message) {
    pc_logf(&F->core, PC_ERROR, "logStatusError", "%s: %s", function, message);
    return fmi2Error;
}

static uint32_t guid_hash(void) {
    const char* s = PC_GUID;
    uint32_t h = 2166136261u;
    while (*s) { h ^= (uint8_t)*s++; h *= 16777619u; }
    return h;
}

/* ------------------------------------------------------------------------------------ lifecycle */
FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    ((pc_fmi2_t*)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    pc_fmi2_t* F;
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
    F = (pc_fmi2_t*)calloc(1, sizeof(pc_fmi2_t));
    if (!F) return NULL;
    F->name = (char*)malloc(strlen(instanceName) + 1);
    if (!F->name) { free(F); return NULL; }
    strcpy(F->name, instanceName);
    F->cb = *functions;
    F->logging = loggingOn ? 1 : 0;
    F->core.log = log_trampoline;
    F->core.log_env = F;
    if (pc_setup(&F->core)) {
        pc_teardown(&F->core);
        free(F->name);
        free(F);
        return NULL;
    }
    pc_defaults(&F->core);
    F->core.c.mode = PC_MODE_INSTANTIATED;
    return F;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    if (!F) return;
    pc_teardown(&F->core);
    free(F->name);
    free(F);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (F->core.c.mode != PC_MODE_INSTANTIATED) return fail(F, "fmi2SetupExperiment", "only allowed after fmi2Instantiate");
    F->core.c.time = startTime;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    if (F->core.c.mode != PC_MODE_INSTANTIATED) return fail(F, "fmi2EnterInitializationMode", "wrong state");
    F->core.c.mode = PC_MODE_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    if (F->core.c.mode != PC_MODE_INIT) return fail(F, "fmi2ExitInitializationMode", "wrong state");
    F->core.c.mode = PC_MODE_STEP;
    F->core.out_valid = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    F->core.c.mode = PC_MODE_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    pc_defaults(&F->core);
    F->core.c.mode = PC_MODE_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ values */
static int usable(pc_fmi2_t* F) { return F->core.c.mode != PC_MODE_TERMINATED && F->core.c.mode != PC_MODE_ERROR; }

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    pc_inst_t* S = &F->core;
    size_t k;
    for (k = 0; k < nvr; k++) {
        fmi2ValueReference r = vr[k];
        if (r < PC_VR_DX) value[k] = S->c.x[r - PC_VR_X];
        else if (r < PC_VR_Y) {
            if (pc_update_outputs(S)) return fail(F, "fmi2GetReal", "output evaluation failed");
            value[k] = S->xdot[r - PC_VR_DX];
        } else if (r < PC_VR_P) {
            if (pc_update_outputs(S)) return fail(F, "fmi2GetReal", "output evaluation failed");
            value[k] = S->y[r - PC_VR_Y];
        } else if (r < PC_VR_U) value[k] = S->c.p[r - PC_VR_P];
        else if (r < PC_VR_XC) value[k] = S->c.u[r - PC_VR_U];
        else if (r < PC_VR_RESET) value[k] = S->c.xc[r - PC_VR_XC];
        else if (r == PC_VR_RESET) value[k] = S->c.reset;
        else if (r == PC_VR_JREQ) value[k] = S->c.jreq;
#if PC_STEP_JACOBIAN
        else if (r >= PC_VR_JAC && r < PC_VR_JAC + PC_NJAC) value[k] = S->c.jac[r - PC_VR_JAC];
#endif
        else return fail(F, "fmi2GetReal", "unknown value reference");
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    pc_inst_t* S = &F->core;
    size_t k;
    if (!usable(F)) return fail(F, "fmi2SetReal", "the instance is terminated or in error");
    for (k = 0; k < nvr; k++) {
        fmi2ValueReference r = vr[k];
        double x = value[k];
        if (r < PC_VR_DX) {
            if (S->c.mode != PC_MODE_INSTANTIATED && S->c.mode != PC_MODE_INIT)
                return fail(F, "fmi2SetReal",
                            "a state can only be set before fmi2ExitInitializationMode; correct it with the "
                            "x_corr inputs and reset = 1 (applied at the start of fmi2DoStep)");
            S->c.x[r - PC_VR_X] = x;
            S->c.xc[r - PC_VR_X] = x;
        } else if (r >= PC_VR_P && r < PC_VR_U) {
            int i = (int)(r - PC_VR_P);
            if (!(x >= PC_P_MIN[i]) || !(x < INFINITY) || (PC_HAS_TARGET && i == 0 && !(x > PC_P_MIN[0]))) {
                pc_logf(S, PC_ERROR, "logStatusError", "fmi2SetReal: parameter %s = %.17g is out of range (min %.17g)",
                        PC_P_NAMES[i], x, PC_P_MIN[i]);
                return fmi2Error;
            }
            S->c.p[i] = x;
        } else if (r >= PC_VR_U && r < PC_VR_XC) S->c.u[r - PC_VR_U] = x;
        else if (r >= PC_VR_XC && r < PC_VR_RESET) S->c.xc[r - PC_VR_XC] = x;
        else if (r == PC_VR_RESET) S->c.reset = x;
        else if (r == PC_VR_JREQ) S->c.jreq = x;
        else return fail(F, "fmi2SetReal", "the variable is not settable (an output or an unknown value reference)");
    }
    S->out_valid = 0;
    return fmi2OK;
}

#define PC_NO_VARIABLES(fn, type)                                                                   \
    FMI2_Export fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[]) { \
        (void)vr; (void)value;                                                                      \
        return nvr ? fail((pc_fmi2_t*)c, #fn, "this FMU has Real variables only") : fmi2OK;         \
    }
PC_NO_VARIABLES(fmi2GetInteger, fmi2Integer)
PC_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean)
PC_NO_VARIABLES(fmi2GetString, fmi2String)
PC_NO_VARIABLES(fmi2SetInteger, const fmi2Integer)
PC_NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean)
PC_NO_VARIABLES(fmi2SetString, const fmi2String)

/* ------------------------------------------------------------------------------------ FMU state */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    if (!*state) *state = malloc(sizeof(pc_core_t));
    if (!*state) return fail(F, "fmi2GetFMUstate", "out of memory");
    memcpy(*state, &F->core.c, sizeof(pc_core_t));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    if (!state) return fail(F, "fmi2SetFMUstate", "null state");
    memcpy(&F->core.c, state, sizeof(pc_core_t));
    F->core.out_valid = 0;
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
    *size = PC_HEADER_SIZE + sizeof(pc_core_t);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    uint32_t header[4] = {PC_STATE_MAGIC, PC_STATE_VERSION, (uint32_t)sizeof(pc_core_t), 0};
    header[3] = guid_hash();
    if (size < PC_HEADER_SIZE + sizeof(pc_core_t)) return fail((pc_fmi2_t*)c, "fmi2SerializeFMUstate", "buffer too small");
    memcpy(bytes, header, PC_HEADER_SIZE);
    memcpy(bytes + PC_HEADER_SIZE, state, sizeof(pc_core_t));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    uint32_t header[4];
    if (size != PC_HEADER_SIZE + sizeof(pc_core_t)) return fail(F, "fmi2DeSerializeFMUstate", "wrong size");
    memcpy(header, bytes, PC_HEADER_SIZE);
    if (header[0] != PC_STATE_MAGIC || header[1] != PC_STATE_VERSION || header[2] != sizeof(pc_core_t) ||
        header[3] != guid_hash())
        return fail(F, "fmi2DeSerializeFMUstate", "not a state of this FMU");
    if (!*state) *state = malloc(sizeof(pc_core_t));
    if (!*state) return fail(F, "fmi2DeSerializeFMUstate", "out of memory");
    memcpy(*state, bytes + PC_HEADER_SIZE, sizeof(pc_core_t));
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ derivatives */
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
#if PC_DIRECTIONAL
    double dx[PC_NX], du[PC_NU], dxdot[PC_NX], dy[PC_NY];
    size_t k;
    memset(dx, 0, sizeof dx);
    memset(du, 0, sizeof du);
    for (k = 0; k < nKnown; k++) {
        fmi2ValueReference r = vKnown_ref[k];
        if (r < PC_VR_DX) dx[r - PC_VR_X] += dvKnown[k];
        else if (r >= PC_VR_U && r < PC_VR_XC) du[r - PC_VR_U] += dvKnown[k];
        else return fail(F, "fmi2GetDirectionalDerivative", "a known must be a state or an input (force, torque, joint)");
    }
    if (pc_directional(&F->core, dx, du, dxdot, dy)) return fail(F, "fmi2GetDirectionalDerivative", "evaluation failed");
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
    return nvr ? fail((pc_fmi2_t*)c, "fmi2SetRealInputDerivatives", "inputs are held constant over a step") : fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? fail((pc_fmi2_t*)c, "fmi2GetRealOutputDerivatives", "output derivatives are not provided") : fmi2OK;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    pc_fmi2_t* F = (pc_fmi2_t*)c;
    pc_inst_t* S = &F->core;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (S->c.mode != PC_MODE_STEP) return fail(F, "fmi2DoStep", "not in step mode");
    if (!(communicationStepSize > 0.0)) return fail(F, "fmi2DoStep", "the communication step size must be positive");
    if (S->c.reset > 0.5) memcpy(S->c.x, S->c.xc, sizeof S->c.x);
    if (pc_step(S, currentCommunicationPoint, communicationStepSize, S->c.jreq > 0.5)) {
        S->c.mode = PC_MODE_ERROR;
        pc_logf(S, PC_ERROR, "logStatusError", "fmi2DoStep: the step from t = %.17g s failed (status %s)",
                currentCommunicationPoint, status_name(fmi2Error));
        return fmi2Error;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    return fail((pc_fmi2_t*)c, "fmi2CancelStep", "steps are synchronous");
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
    (void)c;
    if (s != fmi2DoStepStatus) return fmi2Discard;
    *value = fmi2OK;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = ((pc_fmi2_t*)c)->core.c.time;
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
