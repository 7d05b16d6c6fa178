/*
 * postcapture FMU: the FMI 2.0 co-simulation interface around the exported plant (pc_fmu.c).
 *
 * This file only maps FMI 2.0's calls, types and lifecycle (setup, initialisation, step mode) onto the
 * instance every postcapture FMU shares; the plant, its variables, checks, step rule, Jacobians and FMU
 * state are in pc_fmu.c, the same code as the FMI 3.0 wrapper's (pc_fmi3.c).
 *
 * State correction (the standard forbids fmi2SetReal on states after initialisation): set the inputs
 * x_corr[...] and reset = 1; at the start of the next fmi2DoStep the state is replaced by x_corr (its
 * quaternion checked and normalised). Step Jacobian: set jacobian_request = 1; after fmi2DoStep the
 * outputs F, G, H, Hp hold the exact derivatives of that communication step and jacobian_valid is 1
 * (otherwise they are 0 and jacobian_valid is 0).
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "pc_fmu.h"

typedef struct {
    pc_fmu_t* F;
    fmi2CallbackFunctions cb;
} pc_fmi2_t;

#define FMU(c) (((pc_fmi2_t*)(c))->F)

static void fmi2_log(void* env, const char* instance, int status, const char* category, const char* message) {
    const fmi2CallbackFunctions* cb = (const fmi2CallbackFunctions*)env;
    if (cb->logger) cb->logger(cb->componentEnvironment, instance, (fmi2Status)status, category, "%s", message);
}

/* ------------------------------------------------------------------------------------ lifecycle */
FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    FMU(c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    pc_fmi2_t* W;
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
    W = (pc_fmi2_t*)calloc(1, sizeof(pc_fmi2_t));
    if (!W) return NULL;
    W->cb = *functions;
    W->F = pc_fmu_new("fmi2Instantiate", instanceName, fmi2_log, &W->cb, loggingOn ? 1 : 0);
    if (!W->F) {
        free(W);
        return NULL;
    }
    return W;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    pc_fmu_free(FMU(c));
    free(c);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    return (fmi2Status)pc_fmu_start(FMU(c), "fmi2SetupExperiment", startTime);
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    pc_fmu_t* F = FMU(c);
    if (F->c.mode != PC_MODE_INSTANTIATED) return (fmi2Status)pc_fmu_fail(F, "fmi2EnterInitializationMode", "wrong state");
    F->c.mode = PC_MODE_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return (fmi2Status)pc_fmu_exit_init(FMU(c), "fmi2ExitInitializationMode");
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    FMU(c)->c.mode = PC_MODE_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    pc_fmu_defaults(FMU(c));
    return fmi2OK;
}

/* ------------------------------------------------------------------------------------ values */
FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    return (fmi2Status)pc_fmu_get(FMU(c), "fmi2GetReal", vr, nvr, value);
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    return (fmi2Status)pc_fmu_set(FMU(c), "fmi2SetReal", vr, nvr, value);
}

#define PC_NO_VARIABLES(fn, type)                                                                   \
    FMI2_Export fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[]) { \
        (void)vr; (void)value;                                                                      \
        return nvr ? (fmi2Status)pc_fmu_fail(FMU(c), #fn, "this FMU has Real variables only") : fmi2OK; \
    }
PC_NO_VARIABLES(fmi2GetInteger, fmi2Integer)
PC_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean)
PC_NO_VARIABLES(fmi2GetString, fmi2String)
PC_NO_VARIABLES(fmi2SetInteger, const fmi2Integer)
PC_NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean)
PC_NO_VARIABLES(fmi2SetString, const fmi2String)

/* ------------------------------------------------------------------------------------ FMU state */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
    return (fmi2Status)pc_fmu_get_state(FMU(c), "fmi2GetFMUstate", state);
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return (fmi2Status)pc_fmu_set_state(FMU(c), "fmi2SetFMUstate", state);
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state) {
    (void)c;
    pc_fmu_free_state(state);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size) {
    (void)c; (void)state;
    *size = pc_fmu_serialized_size();
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    return (fmi2Status)pc_fmu_serialize(FMU(c), "fmi2SerializeFMUstate", state, bytes, size);
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
    return (fmi2Status)pc_fmu_deserialize(FMU(c), "fmi2DeSerializeFMUstate", bytes, size, state);
}

/* ------------------------------------------------------------------------------------ derivatives */
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    return (fmi2Status)pc_fmu_directional(FMU(c), "fmi2GetDirectionalDerivative", vUnknown_ref, nUnknown, vKnown_ref,
                                          nKnown, dvKnown, dvUnknown);
}

/* ------------------------------------------------------------------------------------ co-simulation */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? (fmi2Status)pc_fmu_fail(FMU(c), "fmi2SetRealInputDerivatives", "inputs are held constant over a step")
               : fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? (fmi2Status)pc_fmu_fail(FMU(c), "fmi2GetRealOutputDerivatives", "output derivatives are not provided")
               : fmi2OK;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)pc_fmu_do_step(FMU(c), "fmi2DoStep", currentCommunicationPoint, communicationStepSize);
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    return (fmi2Status)pc_fmu_fail(FMU(c), "fmi2CancelStep", "steps are synchronous");
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
    if (s != fmi2DoStepStatus) return fmi2Discard;
    *value = FMU(c)->c.mode == PC_MODE_ERROR ? fmi2Error : fmi2OK;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = FMU(c)->c.last_ok_time;
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
