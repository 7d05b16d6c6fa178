/*
 * postcapture FMUs: the FMI 3.0 functions that the plant's wrapper (pc_fmi3.c) and the estimator's
 * (pc_est_fmi3.c) map alike onto their instance: Float64 values, FMU state, the step, and every call of the
 * API neither FMU offers (other variable types, clocks, event and configuration modes, model exchange,
 * scheduled execution, adjoint and output derivatives), which returns fmi3Error with a logged message: they
 * exist only because an FMI 3.0 binary exports every function of the API. Included once, by a wrapper,
 * after it defines:
 *
 *   PC_WRAP_TYPE          its instance's type (it has an int `logging`)
 *   PC_WRAP_API(name)     its instance's function `name`: new, free, defaults, fail, exit_init, get, set,
 *                         do_step, get_state, set_state, free_state, serialize, deserialize (the signatures
 *                         of pc_fmu.h)
 *   PC_WRAP_TERMINATE(c)  puts the instance in its terminated state
 *   PC_WRAP_LAST_OK(c)    the last successful communication point
 *   PC_WRAP_STATE_SIZE(c) the bytes of a serialised FMU state
 *   PC_WRAP_TOKEN         the instantiation token of the binary
 *
 * and it uses PC_WRAP_SELF(c), the instance of an fmi3Instance. Instantiation (co-simulation only, without
 * event mode: the arguments for intermediate updates and early return are ignored), leaving initialisation,
 * termination and reset are here too; the wrapper keeps fmi3EnterInitializationMode. With
 * PC_WRAP_NO_DIRECTIONAL defined, fmi3GetDirectionalDerivative is here too (refused); otherwise the wrapper
 * provides it.
 */
#ifndef PC_FMI3_COMMON_H
#define PC_FMI3_COMMON_H

#include <stdlib.h>
#include <string.h>

typedef struct {
    void* F; /* PC_WRAP_TYPE */
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} pc_fmi3_wrap_t;

#define PC_WRAP_SELF(c) ((PC_WRAP_TYPE*)((pc_fmi3_wrap_t*)(c))->F)

static void fmi3_log(void* env, const char* instance, int status, const char* category, const char* message) {
    const pc_fmi3_wrap_t* W = (const pc_fmi3_wrap_t*)env;
    (void)instance;
    if (W->log) W->log(W->env, (fmi3Status)status, category, message);
}

static fmi3Status unsupported(fmi3Instance c, const char* function, const char* what) {
    return (fmi3Status)PC_WRAP_API(fail)(PC_WRAP_SELF(c), function, "%s", what);
}

static fmi3Status sizes(fmi3Instance c, const char* function, size_t n_refs, size_t n_values) {
    if (n_refs == n_values) return fmi3OK;
    return (fmi3Status)PC_WRAP_API(fail)(PC_WRAP_SELF(c), function, "%lu values for %lu value references: every variable is a scalar",
                                   (unsigned long)n_values, (unsigned long)n_refs);
}

FMI3_Export const char* fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                                           const fmi3String categories[]) {
    (void)nCategories; (void)categories;
    PC_WRAP_SELF(c)->logging = loggingOn ? 1 : 0;
    return fmi3OK;
}

static void refuse_instance(fmi3InstanceEnvironment env, fmi3LogMessageCallback log, const char* what) {
    if (log) log(env, fmi3Error, "logStatusError", what);
}

FMI3_Export fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                                      fmi3String resourcePath, fmi3Boolean visible,
                                                      fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                                      fmi3LogMessageCallback logMessage) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    refuse_instance(instanceEnvironment, logMessage, "fmi3InstantiateModelExchange: this FMU supports co-simulation only");
    return NULL;
}

FMI3_Export fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
    fmi3ClockUpdateCallback clockUpdate, fmi3LockPreemptionCallback lockPreemption,
    fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    refuse_instance(instanceEnvironment, logMessage, "fmi3InstantiateScheduledExecution: this FMU supports co-simulation only");
    return NULL;
}

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference requiredIntermediateVariables[], size_t nRequiredIntermediateVariables,
    fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
    fmi3IntermediateUpdateCallback intermediateUpdate) {
    pc_fmi3_wrap_t* W;
    (void)resourcePath; (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (!instanceName) return NULL;
    if (!instantiationToken || strcmp(instantiationToken, PC_WRAP_TOKEN) != 0) {
        refuse_instance(instanceEnvironment, logMessage,
                        "fmi3InstantiateCoSimulation: the instantiation token does not match the binary's " PC_WRAP_TOKEN);
        return NULL;
    }
    if (eventModeUsed) {
        refuse_instance(instanceEnvironment, logMessage,
                        "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no event mode "
                        "(hasEventMode is false)");
        return NULL;
    }
    W = (pc_fmi3_wrap_t*)calloc(1, sizeof(pc_fmi3_wrap_t));
    if (!W) return NULL;
    W->env = instanceEnvironment;
    W->log = logMessage;
    W->F = PC_WRAP_API(new)("fmi3InstantiateCoSimulation", instanceName, fmi3_log, W, loggingOn ? 1 : 0);
    if (!W->F) {
        free(W);
        return NULL;
    }
    return W;
}

FMI3_Export void fmi3FreeInstance(fmi3Instance c) {
    if (!c) return;
    PC_WRAP_API(free)(PC_WRAP_SELF(c));
    free(c);
}

FMI3_Export fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    return (fmi3Status)PC_WRAP_API(exit_init)(PC_WRAP_SELF(c), "fmi3ExitInitializationMode");
}

FMI3_Export fmi3Status fmi3Terminate(fmi3Instance c) {
    PC_WRAP_TERMINATE(c);
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3Reset(fmi3Instance c) {
    PC_WRAP_API(defaults)(PC_WRAP_SELF(c));
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    return unsupported(c, "fmi3EnterEventMode", "this FMU has no event mode");
}

/* ------------------------------------------------------------------------------------ values */
FMI3_Export fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                                      size_t nValues) {
    if (sizes(c, "fmi3GetFloat64", nvr, nValues) != fmi3OK) return fmi3Error;
    return (fmi3Status)PC_WRAP_API(get)(PC_WRAP_SELF(c), "fmi3GetFloat64", vr, nvr, values);
}

FMI3_Export fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                      const fmi3Float64 values[], size_t nValues) {
    if (sizes(c, "fmi3SetFloat64", nvr, nValues) != fmi3OK) return fmi3Error;
    return (fmi3Status)PC_WRAP_API(set)(PC_WRAP_SELF(c), "fmi3SetFloat64", vr, nvr, values);
}

#define PC_NO_VARIABLES(fn, type)                                                                                \
    FMI3_Export fmi3Status fn(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, type values[], size_t n) { \
        (void)vr; (void)values; (void)n;                                                                         \
        return nvr ? unsupported(c, #fn, "this FMU has Float64 variables only") : fmi3OK;                      \
    }
PC_NO_VARIABLES(fmi3GetFloat32, fmi3Float32)
PC_NO_VARIABLES(fmi3GetInt8, fmi3Int8)
PC_NO_VARIABLES(fmi3GetUInt8, fmi3UInt8)
PC_NO_VARIABLES(fmi3GetInt16, fmi3Int16)
PC_NO_VARIABLES(fmi3GetUInt16, fmi3UInt16)
PC_NO_VARIABLES(fmi3GetInt32, fmi3Int32)
PC_NO_VARIABLES(fmi3GetUInt32, fmi3UInt32)
PC_NO_VARIABLES(fmi3GetInt64, fmi3Int64)
PC_NO_VARIABLES(fmi3GetUInt64, fmi3UInt64)
PC_NO_VARIABLES(fmi3GetBoolean, fmi3Boolean)
PC_NO_VARIABLES(fmi3GetString, fmi3String)
PC_NO_VARIABLES(fmi3SetFloat32, const fmi3Float32)
PC_NO_VARIABLES(fmi3SetInt8, const fmi3Int8)
PC_NO_VARIABLES(fmi3SetUInt8, const fmi3UInt8)
PC_NO_VARIABLES(fmi3SetInt16, const fmi3Int16)
PC_NO_VARIABLES(fmi3SetUInt16, const fmi3UInt16)
PC_NO_VARIABLES(fmi3SetInt32, const fmi3Int32)
PC_NO_VARIABLES(fmi3SetUInt32, const fmi3UInt32)
PC_NO_VARIABLES(fmi3SetInt64, const fmi3Int64)
PC_NO_VARIABLES(fmi3SetUInt64, const fmi3UInt64)
PC_NO_VARIABLES(fmi3SetBoolean, const fmi3Boolean)
PC_NO_VARIABLES(fmi3SetString, const fmi3String)
#undef PC_NO_VARIABLES

FMI3_Export fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                                     fmi3Binary values[], size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr ? unsupported(c, "fmi3GetBinary", "this FMU has Float64 variables only") : fmi3OK;
}

FMI3_Export fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t valueSizes[],
                                     const fmi3Binary values[], size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr ? unsupported(c, "fmi3SetBinary", "this FMU has Float64 variables only") : fmi3OK;
}

FMI3_Export fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
    (void)vr; (void)values;
    return nvr ? unsupported(c, "fmi3GetClock", "this FMU has no clocks") : fmi3OK;
}

FMI3_Export fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
    (void)vr; (void)values;
    return nvr ? unsupported(c, "fmi3SetClock", "this FMU has no clocks") : fmi3OK;
}

FMI3_Export fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference valueReference,
                                                           size_t* nDependencies) {
    (void)valueReference; (void)nDependencies;
    return unsupported(c, "fmi3GetNumberOfVariableDependencies", "the dependencies are in modelDescription.xml only");
}

FMI3_Export fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent,
                                                   size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                                   size_t elementIndicesOfIndependents[],
                                                   fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    return unsupported(c, "fmi3GetVariableDependencies", "the dependencies are in modelDescription.xml only");
}

/* ------------------------------------------------------------------------------------ FMU state */
FMI3_Export fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState* state) {
    return (fmi3Status)PC_WRAP_API(get_state)(PC_WRAP_SELF(c), "fmi3GetFMUState", state);
}

FMI3_Export fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    return (fmi3Status)PC_WRAP_API(set_state)(PC_WRAP_SELF(c), "fmi3SetFMUState", state);
}

FMI3_Export fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState* state) {
    (void)c;
    PC_WRAP_API(free_state)(state);
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t* size) {
    (void)state;
    *size = PC_WRAP_STATE_SIZE(c);
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte serializedState[], size_t size) {
    return (fmi3Status)PC_WRAP_API(serialize)(PC_WRAP_SELF(c), "fmi3SerializeFMUState", state, (char*)serializedState,
                                              size);
}

FMI3_Export fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                               fmi3FMUState* state) {
    return (fmi3Status)PC_WRAP_API(deserialize)(PC_WRAP_SELF(c), "fmi3DeserializeFMUState",
                                                (const char*)serializedState, size, state);
}
/* ------------------------------------------------------------------------------------ derivatives */
#ifdef PC_WRAP_NO_DIRECTIONAL
FMI3_Export fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[],
                                                    size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                                    const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                                    size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetDirectionalDerivative", "directional derivatives are not provided");
}
#endif

FMI3_Export fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                                const fmi3ValueReference knowns[], size_t nKnowns,
                                                const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                                size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetAdjointDerivative", "adjoint derivatives are not provided (use directional ones)");
}

/* ------------------------------------------------------------------------------------ co-simulation */
FMI3_Export fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    return unsupported(c, "fmi3EnterStepMode", "this FMU has no event mode: it is in step mode after initialisation");
}

FMI3_Export fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                                const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    (void)vr; (void)orders; (void)values; (void)nValues;
    return nvr ? unsupported(c, "fmi3GetOutputDerivatives", "output derivatives are not provided") : fmi3OK;
}

FMI3_Export fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                                  fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                                  fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn,
                                  fmi3Float64* lastSuccessfulTime) {
    int status = PC_WRAP_API(do_step)(PC_WRAP_SELF(c), "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = PC_WRAP_LAST_OK(c);
    return (fmi3Status)status;
}

/* ------------------------------------------------------------------------------------ not offered */
#define PC_UNSUPPORTED(fn, what, ...)                                \
    FMI3_Export fmi3Status fn(fmi3Instance c, __VA_ARGS__) {        \
        return unsupported(c, #fn, what);                           \
    }
#define PC_UNSUPPORTED0(fn, what)                                    \
    FMI3_Export fmi3Status fn(fmi3Instance c) { return unsupported(c, #fn, what); }

PC_UNSUPPORTED0(fmi3EnterConfigurationMode, "this FMU has no structural parameters")
PC_UNSUPPORTED0(fmi3ExitConfigurationMode, "this FMU has no structural parameters")
PC_UNSUPPORTED(fmi3GetIntervalDecimal, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
PC_UNSUPPORTED(fmi3GetIntervalFraction, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
PC_UNSUPPORTED(fmi3GetShiftDecimal, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               fmi3Float64 shifts[])
PC_UNSUPPORTED(fmi3GetShiftFraction, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               fmi3UInt64 counters[], fmi3UInt64 resolutions[])
PC_UNSUPPORTED(fmi3SetIntervalDecimal, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               const fmi3Float64 intervals[])
PC_UNSUPPORTED(fmi3SetIntervalFraction, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
PC_UNSUPPORTED(fmi3SetShiftDecimal, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               const fmi3Float64 shifts[])
PC_UNSUPPORTED(fmi3SetShiftFraction, "this FMU has no clocks", const fmi3ValueReference vr[], size_t nvr,
               const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
PC_UNSUPPORTED0(fmi3EvaluateDiscreteStates, "this FMU has no event mode")
PC_UNSUPPORTED(fmi3UpdateDiscreteStates, "this FMU has no event mode", fmi3Boolean* discreteStatesNeedUpdate,
               fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged,
               fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,
               fmi3Float64* nextEventTime)
PC_UNSUPPORTED0(fmi3EnterContinuousTimeMode, "this FMU supports co-simulation only")
PC_UNSUPPORTED(fmi3CompletedIntegratorStep, "this FMU supports co-simulation only",
               fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* enterEventMode,
               fmi3Boolean* terminateSimulation)
PC_UNSUPPORTED(fmi3SetTime, "this FMU supports co-simulation only", fmi3Float64 time)
PC_UNSUPPORTED(fmi3SetContinuousStates, "this FMU supports co-simulation only", const fmi3Float64 x[], size_t nx)
PC_UNSUPPORTED(fmi3GetContinuousStateDerivatives, "this FMU supports co-simulation only", fmi3Float64 derivatives[],
               size_t nx)
PC_UNSUPPORTED(fmi3GetEventIndicators, "this FMU supports co-simulation only", fmi3Float64 indicators[], size_t ni)
PC_UNSUPPORTED(fmi3GetContinuousStates, "this FMU supports co-simulation only", fmi3Float64 x[], size_t nx)
PC_UNSUPPORTED(fmi3GetNominalsOfContinuousStates, "this FMU supports co-simulation only", fmi3Float64 nominals[],
               size_t nx)
PC_UNSUPPORTED(fmi3GetNumberOfEventIndicators, "this FMU supports co-simulation only", size_t* ni)
PC_UNSUPPORTED(fmi3GetNumberOfContinuousStates, "this FMU supports co-simulation only", size_t* nx)
PC_UNSUPPORTED(fmi3ActivateModelPartition, "this FMU supports co-simulation only", fmi3ValueReference clockReference,
               fmi3Float64 activationTime)

#undef PC_UNSUPPORTED
#undef PC_UNSUPPORTED0

#endif
