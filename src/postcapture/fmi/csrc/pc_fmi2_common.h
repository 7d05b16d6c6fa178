/*
 * postcapture FMUs: the FMI 2.0 functions that the plant's wrapper (pc_fmi2.c) and the estimator's
 * (pc_est_fmi2.c) map alike onto their instance: values, FMU state, the step, the status getters and the
 * calls neither FMU offers, instantiation and the logger. Included once, by a wrapper, after it defines:
 *
 *   PC_WRAP_TYPE          its instance's type (it has an int `logging`)
 *   PC_WRAP_API(name)     its instance's function `name`: new, free, defaults, fail, exit_init, get, set,
 *                         do_step, get_state, set_state, free_state, serialize, deserialize (the signatures
 *                         of pc_fmu.h)
 *   PC_WRAP_TERMINATE(c)  puts the instance in its terminated state
 *   PC_WRAP_IN_ERROR(c)   nonzero when the instance is in its error state
 *   PC_WRAP_LAST_OK(c)    the last successful communication point
 *   PC_WRAP_STATE_SIZE(c) the bytes of a serialised FMU state
 *   PC_WRAP_TOKEN         the GUID of the binary
 *
 * and it uses PC_WRAP_SELF(c), the instance of a component. With PC_WRAP_NO_DIRECTIONAL defined,
 * fmi2GetDirectionalDerivative is here too (refused); otherwise the wrapper provides it. The wrapper keeps
 * fmi2SetupExperiment and fmi2EnterInitializationMode.
 */
#ifndef PC_FMI2_COMMON_H
#define PC_FMI2_COMMON_H

#include <stdlib.h>
#include <string.h>

typedef struct {
    void* F; /* PC_WRAP_TYPE */
    fmi2CallbackFunctions cb;
} pc_fmi2_wrap_t;

#define PC_WRAP_SELF(c) ((PC_WRAP_TYPE*)((pc_fmi2_wrap_t*)(c))->F)
#define PC_WRAP_FAIL(c, function, what) ((fmi2Status)PC_WRAP_API(fail)(PC_WRAP_SELF(c), function, "%s", what))

static void fmi2_log(void* env, const char* instance, int status, const char* category, const char* message) {
    const fmi2CallbackFunctions* cb = (const fmi2CallbackFunctions*)env;
    if (cb->logger) cb->logger(cb->componentEnvironment, instance, (fmi2Status)status, category, "%s", message);
}

/* ------------------------------------------------------------------------------------ lifecycle */
FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    pc_fmi2_wrap_t* W;
    (void)resourceLocation; (void)visible;
    if (!functions || !instanceName) return NULL;
    if (fmuType != fmi2CoSimulation) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: this FMU supports co-simulation only");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, PC_WRAP_TOKEN) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: GUID %s does not match the binary's %s", fmuGUID ? fmuGUID : "(null)",
                              PC_WRAP_TOKEN);
        return NULL;
    }
    W = (pc_fmi2_wrap_t*)calloc(1, sizeof(pc_fmi2_wrap_t));
    if (!W) return NULL;
    W->cb = *functions;
    W->F = PC_WRAP_API(new)("fmi2Instantiate", instanceName, fmi2_log, &W->cb, loggingOn ? 1 : 0);
    if (!W->F) {
        free(W);
        return NULL;
    }
    return W;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    PC_WRAP_API(free)(PC_WRAP_SELF(c));
    free(c);
}

FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    PC_WRAP_SELF(c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return (fmi2Status)PC_WRAP_API(exit_init)(PC_WRAP_SELF(c), "fmi2ExitInitializationMode");
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    PC_WRAP_TERMINATE(c);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    PC_WRAP_API(defaults)(PC_WRAP_SELF(c));
    return fmi2OK;
}

#ifdef PC_WRAP_NO_DIRECTIONAL
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz, const fmi2Real dv[],
                                                    fmi2Real dz[]) {
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return PC_WRAP_FAIL(c, "fmi2GetDirectionalDerivative", "directional derivatives are not provided");
}
#endif

/* ------------------------------------------------------------------------------------ values */
FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    return (fmi2Status)PC_WRAP_API(get)(PC_WRAP_SELF(c), "fmi2GetReal", vr, nvr, value);
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    return (fmi2Status)PC_WRAP_API(set)(PC_WRAP_SELF(c), "fmi2SetReal", vr, nvr, value);
}

#define PC_NO_VARIABLES(fn, type)                                                                   \
    FMI2_Export fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[]) { \
        (void)vr; (void)value;                                                                      \
        return nvr ? PC_WRAP_FAIL(c, #fn, "this FMU has Real variables only") : fmi2OK;             \
    }
PC_NO_VARIABLES(fmi2GetInteger, fmi2Integer)
PC_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean)
PC_NO_VARIABLES(fmi2GetString, fmi2String)
PC_NO_VARIABLES(fmi2SetInteger, const fmi2Integer)
PC_NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean)
PC_NO_VARIABLES(fmi2SetString, const fmi2String)
#undef PC_NO_VARIABLES

/* ------------------------------------------------------------------------------------ FMU state */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
    return (fmi2Status)PC_WRAP_API(get_state)(PC_WRAP_SELF(c), "fmi2GetFMUstate", state);
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return (fmi2Status)PC_WRAP_API(set_state)(PC_WRAP_SELF(c), "fmi2SetFMUstate", state);
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state) {
    (void)c;
    PC_WRAP_API(free_state)(state);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size) {
    (void)state;
    *size = PC_WRAP_STATE_SIZE(c);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    return (fmi2Status)PC_WRAP_API(serialize)(PC_WRAP_SELF(c), "fmi2SerializeFMUstate", state, bytes, size);
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state) {
    return (fmi2Status)PC_WRAP_API(deserialize)(PC_WRAP_SELF(c), "fmi2DeSerializeFMUstate", bytes, size, state);
}

/* ------------------------------------------------------------------------------------ co-simulation */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? PC_WRAP_FAIL(c, "fmi2SetRealInputDerivatives", "inputs are held constant over a step") : fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    return nvr ? PC_WRAP_FAIL(c, "fmi2GetRealOutputDerivatives", "output derivatives are not provided") : fmi2OK;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)PC_WRAP_API(do_step)(PC_WRAP_SELF(c), "fmi2DoStep", currentCommunicationPoint,
                                            communicationStepSize);
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    return PC_WRAP_FAIL(c, "fmi2CancelStep", "steps are synchronous");
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
    if (s != fmi2DoStepStatus) return fmi2Discard;
    *value = PC_WRAP_IN_ERROR(c) ? fmi2Error : fmi2OK;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = PC_WRAP_LAST_OK(c);
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

#endif
