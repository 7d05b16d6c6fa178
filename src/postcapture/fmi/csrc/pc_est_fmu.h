/*
 * postcapture estimator FMU: the instance both FMI wrappers of the estimator (pc_est_fmi2.c, pc_est_fmi3.c)
 * drive, as pc_fmu.h is for the plant's.
 *
 * Everything an estimator FMU does beyond the scheme's cycle (pc_estimator.c) lives here once: the
 * lifecycle and its checks, the setters' validation (a refused call changes nothing), the fixed
 * communication step (the filter's period), the FMU state (get, set, serialise; a state whose quaternions
 * are not unit or whose covariance is not finite and symmetric is refused) and the logged refusals. A
 * wrapper maps its version's calls, types and logger onto these functions. Status codes are FMI's (0 OK,
 * 2 Discard, 3 Error: the same numbers in FMI 2.0 and 3.0).
 */
#ifndef PC_EST_FMU_H
#define PC_EST_FMU_H

#include <stddef.h>

#include "pc_estimator.h"

enum { PCE_FMU_OK = 0, PCE_FMU_DISCARD = 2, PCE_FMU_ERROR = 3 };
enum { PCE_MODE_INSTANTIATED = 0, PCE_MODE_INIT = 1, PCE_MODE_STEP = 2, PCE_MODE_TERMINATED = 3, PCE_MODE_ERROR = 4 };

/* the wrapper's logger: an FMI status, a category and the formatted message */
typedef void (*pce_logger_t)(void* env, const char* instance, int status, const char* category, const char* message);

typedef struct {
    pc_est_t E;
    char* name;
    pce_logger_t log;
    void* env;
    int logging, mode;
    double t0, last_ok;
} pce_fmu_t;

/* NULL (and a logged reason) when the filters cannot be created */
pce_fmu_t* pce_fmu_new(const char* function, const char* name, pce_logger_t log, void* env, int logging);
void pce_fmu_free(pce_fmu_t* F);
int pce_fmu_fail(pce_fmu_t* F, const char* function, const char* fmt, ...);
int pce_fmu_setup(pce_fmu_t* F, const char* function, double start_time);
int pce_fmu_enter_init(pce_fmu_t* F, const char* function);
int pce_fmu_exit_init(pce_fmu_t* F, const char* function);
void pce_fmu_defaults(pce_fmu_t* F);

/* values: value references 0 .. PCE_NREAL - 1 (pc_est_data.h); PCE_VR_TIME, after them, reads the time of the
 * estimates (FMI 3.0's independent variable `time`; an FMI 2.0 description does not declare it) */
#define PCE_VR_TIME PCE_NREAL
int pce_fmu_get(pce_fmu_t* F, const char* function, const unsigned* vr, size_t n, double* value);
int pce_fmu_set(pce_fmu_t* F, const char* function, const unsigned* vr, size_t n, const double* value);

/* one filter cycle from t; any step h other than the filter's period is refused */
int pce_fmu_do_step(pce_fmu_t* F, const char* function, double t, double h);

/* FMU state */
int pce_fmu_get_state(pce_fmu_t* F, const char* function, void** state);
int pce_fmu_set_state(pce_fmu_t* F, const char* function, const void* state);
void pce_fmu_free_state(void** state);
size_t pce_fmu_state_bytes(pce_fmu_t* F);
int pce_fmu_serialize(pce_fmu_t* F, const char* function, const void* state, char* bytes, size_t size);
int pce_fmu_deserialize(pce_fmu_t* F, const char* function, const char* bytes, size_t size, void** state);

#endif
