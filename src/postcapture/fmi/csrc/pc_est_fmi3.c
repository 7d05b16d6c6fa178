/*
 * postcapture estimator FMU: the FMI 3.0 co-simulation interface of the estimator instance (pc_est_fmu.c,
 * the same code as the FMI 2.0 wrapper's). One fmi3DoStep is one filter cycle; a step other than the
 * filter's period returns fmi3Error with a logged message; fmi3SetFMUState and fmi3DeserializeFMUState
 * refuse a state whose quaternions are not unit or whose covariance is not finite and symmetric. Every
 * variable is a Float64; the independent variable `time` (value reference PCE_VR_TIME, after the others)
 * reads the time of the estimates. This file maps fmi3EnterInitializationMode; every other call is mapped as
 * the plant wrapper maps it (pc_fmi3_common.h).
 */
#include "fmi3Functions.h"
#include "pc_est_fmu.h"

#define PC_WRAP_TYPE pce_fmu_t
#define EST(c) PC_WRAP_SELF(c)
#define PC_WRAP_API(name) pce_fmu_##name
#define PC_WRAP_LAST_OK(c) (EST(c)->last_ok)
#define PC_WRAP_STATE_SIZE(c) pce_fmu_state_bytes(EST(c))
#define PC_WRAP_TOKEN PCE_GUID
#define PC_WRAP_TERMINATE(c) (EST(c)->mode = PCE_MODE_TERMINATED)
#define PC_WRAP_NO_DIRECTIONAL
#include "pc_fmi3_common.h" /* the calls both postcapture FMUs map alike */

/* ------------------------------------------------------------------------------------ lifecycle */
FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                                   fmi3Float64 startTime, fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (pce_fmu_setup(EST(c), "fmi3EnterInitializationMode", startTime) != PCE_FMU_OK) return fmi3Error;
    return (fmi3Status)pce_fmu_enter_init(EST(c), "fmi3EnterInitializationMode");
}

