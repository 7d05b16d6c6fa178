/*
 * postcapture FMU: the FMI 3.0 co-simulation interface around the exported plant (pc_fmu.c).
 *
 * This file only maps FMI 3.0's initialisation and directional derivatives onto the instance every
 * postcapture FMU shares (the plant, its variables, checks, step rule, Jacobians and FMU state are in
 * pc_fmu.c, the same code as the FMI 2.0 wrapper's). The FMU offers co-simulation without event mode, intermediate updates
 * or early return; every variable is a Float64 (the independent variable `time` among them). The calls the
 * estimator's FMI 3.0 wrapper maps alike (instantiation, values, FMU state, the step, everything not
 * offered) are in pc_fmi3_common.h.
 */
#include "fmi3Functions.h"
#include "pc_fmu.h"

#define PC_WRAP_TYPE pc_fmu_t
#define FMU(c) PC_WRAP_SELF(c)
#define PC_WRAP_API(name) pc_fmu_##name
#define PC_WRAP_LAST_OK(c) (FMU(c)->c.last_ok_time)
#define PC_WRAP_STATE_SIZE(c) pc_fmu_serialized_size()
#define PC_WRAP_TOKEN PC_GUID
#define PC_WRAP_TERMINATE(c) (FMU(c)->c.mode = PC_MODE_TERMINATED)
#include "pc_fmi3_common.h" /* the calls both postcapture FMUs map alike */

/* ------------------------------------------------------------------------------------ lifecycle */
FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                                   fmi3Float64 startTime, fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime) {
    pc_fmu_t* F = FMU(c);
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (pc_fmu_start(F, "fmi3EnterInitializationMode", startTime) != PC_FMU_OK) return fmi3Error;
    F->c.mode = PC_MODE_INIT;
    return fmi3OK;
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

