/*
 * postcapture FMU: the FMI 2.0 co-simulation interface around the exported plant (pc_fmu.c).
 *
 * This file only maps FMI 2.0's calls, types and lifecycle (setup, initialisation, step mode) onto the
 * instance every postcapture FMU shares; the plant, its variables, checks, step rule, Jacobians and FMU
 * state are in pc_fmu.c, the same code as the FMI 3.0 wrapper's (pc_fmi3.c). The calls the estimator's
 * FMI 2.0 wrapper maps alike (instantiation, values, FMU state, the step, the status getters) are in
 * pc_fmi2_common.h.
 *
 * State correction (the standard forbids fmi2SetReal on states after initialisation): set the inputs
 * x_corr[...] and reset = 1; at the start of the next fmi2DoStep the state is replaced by x_corr (its
 * quaternion checked and normalised). Step Jacobian: set jacobian_request = 1; after fmi2DoStep the
 * outputs F, G, H, Hp hold the exact derivatives of that communication step and jacobian_valid is 1
 * (otherwise they are 0 and jacobian_valid is 0).
 */
#include "fmi2Functions.h"
#include "pc_fmu.h"

#define PC_WRAP_TYPE pc_fmu_t
#define FMU(c) PC_WRAP_SELF(c)
#define PC_WRAP_API(name) pc_fmu_##name
#define PC_WRAP_TOKEN PC_GUID
#define PC_WRAP_IN_ERROR(c) (FMU(c)->c.mode == PC_MODE_ERROR)
#define PC_WRAP_LAST_OK(c) (FMU(c)->c.last_ok_time)
#define PC_WRAP_STATE_SIZE(c) pc_fmu_serialized_size()
#define PC_WRAP_TERMINATE(c) (FMU(c)->c.mode = PC_MODE_TERMINATED)
#include "pc_fmi2_common.h" /* the calls both postcapture FMUs map alike */

/* ------------------------------------------------------------------------------------ lifecycle */
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

/* ------------------------------------------------------------------------------------ derivatives */
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    return (fmi2Status)pc_fmu_directional(FMU(c), "fmi2GetDirectionalDerivative", vUnknown_ref, nUnknown, vKnown_ref,
                                          nKnown, dvKnown, dvUnknown);
}
