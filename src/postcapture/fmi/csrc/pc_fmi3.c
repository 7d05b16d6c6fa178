/*
 * postcapture FMU: the FMI 3.0 co-simulation interface around the exported plant (pc_fmu.c).
 *
 * This file only maps FMI 3.0's calls, types and lifecycle onto the instance every postcapture FMU
 * shares (the plant, its variables, checks, step rule, Jacobians and FMU state are in pc_fmu.c, the same
 * code as the FMI 2.0 wrapper's). The FMU offers co-simulation without event mode, intermediate updates
 * or early return; every variable is a Float64 (the independent variable `time` among them).
 * Directional derivatives are provided (fmi3GetDirectionalDerivative); adjoint derivatives, clocks,
 * configuration mode and the model-exchange and scheduled-execution calls return fmi3Error with a
 * logged message: they exist only because an FMI 3.0 binary exports every function of the API.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "pc_fmu.h"

typedef struct {
    pc_fmu_t* F;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} pc_fmi3_t;

#define FMU(c) (((pc_fmi3_t*)(c))->F)

static void fmi3_log(void* env, const char* instance, int status, const char* category, const char* message) {
    const pc_fmi3_t* W = (const pc_fmi3_t*)env;
    (void)instance;
    if (W->log) W->log(W->env, (fmi3Status)status, category, message);
}

static fmi3Status unsupported(fmi3Instance c, const char* function, const char* what) {
    return (fmi3Status)pc_fmu_fail(FMU(c), function, "%s", what);
}

static fmi3Status sizes(fmi3Instance c, const char* function, size_t n_refs, size_t n_values) {
    if (n_refs == n_values) return fmi3OK;
    return (fmi3Status)pc_fmu_fail(FMU(c), function, "%lu values for %lu value references: every variable is a scalar",
                                   (unsigned long)n_values, (unsigned long)n_refs);
}

/* ------------------------------------------------------------------------------------ lifecycle */
FMI3_Export const char* fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                                           const fmi3String categories[]) {
    (void)nCategories; (void)categories;
    FMU(c)->logging = loggingOn ? 1 : 0;
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
    pc_fmi3_t* W;
    (void)resourcePath; (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (!instanceName) return NULL;
    if (!instantiationToken || strcmp(instantiationToken, PC_GUID) != 0) {
        refuse_instance(instanceEnvironment, logMessage,
                        "fmi3InstantiateCoSimulation: the instantiation token does not match the binary's " PC_GUID);
        return NULL;
    }
    if (eventModeUsed) {
        refuse_instance(instanceEnvironment, logMessage,
                        "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no event mode "
                        "(hasEventMode is false)");
        return NULL;
    }
    W = (pc_fmi3_t*)calloc(1, sizeof(pc_fmi3_t));
    if (!W) return NULL;
    W->env = instanceEnvironment;
    W->log = logMessage;
    W->F = pc_fmu_new("fmi3InstantiateCoSimulation", instanceName, fmi3_log, W, loggingOn ? 1 : 0);
    if (!W->F) {
        free(W);
        return NULL;
    }
    return W;
}

FMI3_Export void fmi3FreeInstance(fmi3Instance c) {
    if (!c) return;
    pc_fmu_free(FMU(c));
    free(c);
}

FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                                   fmi3Float64 startTime, fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime) {
    pc_fmu_t* F = FMU(c);
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (pc_fmu_start(F, "fmi3EnterInitializationMode", startTime) != PC_FMU_OK) return fmi3Error;
    F->c.mode = PC_MODE_INIT;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    return (fmi3Status)pc_fmu_exit_init(FMU(c), "fmi3ExitInitializationMode");
}

FMI3_Export fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    return unsupported(c, "fmi3EnterEventMode", "this FMU has no event mode");
}

FMI3_Export fmi3Status fmi3Terminate(fmi3Instance c) {
    FMU(c)->c.mode = PC_MODE_TERMINATED;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3Reset(fmi3Instance c) {
    pc_fmu_defaults(FMU(c));
    return fmi3OK;
}

/* ------------------------------------------------------------------------------------ values */
FMI3_Export fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                                      size_t nValues) {
    if (sizes(c, "fmi3GetFloat64", nvr, nValues) != fmi3OK) return fmi3Error;
    return (fmi3Status)pc_fmu_get(FMU(c), "fmi3GetFloat64", vr, nvr, values);
}

FMI3_Export fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                      const fmi3Float64 values[], size_t nValues) {
    if (sizes(c, "fmi3SetFloat64", nvr, nValues) != fmi3OK) return fmi3Error;
    return (fmi3Status)pc_fmu_set(FMU(c), "fmi3SetFloat64", vr, nvr, values);
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
    return (fmi3Status)pc_fmu_get_state(FMU(c), "fmi3GetFMUState", state);
}

FMI3_Export fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    return (fmi3Status)pc_fmu_set_state(FMU(c), "fmi3SetFMUState", state);
}

FMI3_Export fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState* state) {
    (void)c;
    pc_fmu_free_state(state);
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t* size) {
    (void)c; (void)state;
    *size = pc_fmu_serialized_size();
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte serializedState[], size_t size) {
    return (fmi3Status)pc_fmu_serialize(FMU(c), "fmi3SerializeFMUState", state, (char*)serializedState, size);
}

FMI3_Export fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                               fmi3FMUState* state) {
    return (fmi3Status)pc_fmu_deserialize(FMU(c), "fmi3DeserializeFMUState", (const char*)serializedState, size, state);
}

/* ------------------------------------------------------------------------------------ derivatives */
FMI3_Export fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[],
                                                    size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                                    const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                                    size_t nSensitivity) {
    if (nSeed != nKnowns || nSensitivity != nUnknowns)
        return (fmi3Status)pc_fmu_fail(FMU(c), "fmi3GetDirectionalDerivative",
                                       "%lu seeds for %lu knowns, %lu sensitivities for %lu unknowns: expected equal "
                                       "counts (scalar variables)", (unsigned long)nSeed, (unsigned long)nKnowns,
                                       (unsigned long)nSensitivity, (unsigned long)nUnknowns);
    return (fmi3Status)pc_fmu_directional(FMU(c), "fmi3GetDirectionalDerivative", unknowns, nUnknowns, knowns, nKnowns,
                                          seed, sensitivity);
}

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
    pc_fmu_t* F = FMU(c);
    int status = pc_fmu_do_step(F, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = F->c.last_ok_time;
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
