/*
 * postcapture estimator FMU: the FMI 2.0 co-simulation interface of the estimator instance (pc_est_fmu.c,
 * shared with the FMI 3.0 wrapper pc_est_fmi3.c). One fmi2DoStep is one filter cycle; a step other than the
 * filter's period returns fmi2Error with a logged message; fmi2SetFMUstate and fmi2DeSerializeFMUstate refuse
 * a state whose quaternions are not unit or whose covariance is not finite and symmetric. This file maps
 * fmi2SetupExperiment and fmi2EnterInitializationMode; every other call is mapped as the plant wrapper
 * maps it (pc_fmi2_common.h).
 */
#include "fmi2Functions.h"
#include "pc_est_fmu.h"

#define PC_WRAP_TYPE pce_fmu_t
#define EST(c) PC_WRAP_SELF(c)
#define PC_WRAP_API(name) pce_fmu_##name
#define PC_WRAP_TOKEN PCE_GUID
#define PC_WRAP_IN_ERROR(c) (EST(c)->mode == PCE_MODE_ERROR)
#define PC_WRAP_LAST_OK(c) (EST(c)->last_ok)
#define PC_WRAP_STATE_SIZE(c) pce_fmu_state_bytes(EST(c))
#define PC_WRAP_TERMINATE(c) (EST(c)->mode = PCE_MODE_TERMINATED)
#define PC_WRAP_NO_DIRECTIONAL
#include "pc_fmi2_common.h" /* the calls both postcapture FMUs map alike */

/* ------------------------------------------------------------------------------------ lifecycle */
FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    return (fmi2Status)pce_fmu_setup(EST(c), "fmi2SetupExperiment", startTime);
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return (fmi2Status)pce_fmu_enter_init(EST(c), "fmi2EnterInitializationMode");
}

