/*
 * postcapture FMU: the instance both FMI wrappers (pc_fmi2.c, pc_fmi3.c) drive.
 *
 * Everything an exported plant does lives here once: its variables and their checks, its state and the
 * rule that turns a communication step into internal steps, the outputs, the exact step Jacobians, the
 * directional derivatives and the FMU state (get, set, serialise, with its validation). A wrapper only
 * maps its FMI version's calls, types and lifecycle onto these functions. Status codes are FMI's
 * (0 OK, 3 Error: the same numbers in FMI 2.0 and 3.0); every refusal is logged through the wrapper's
 * logger with the FMI function's name.
 */
#ifndef PC_FMU_H
#define PC_FMU_H

#include <stddef.h>

#include "pc_fmu_data.h"
#include "pc_plant.h"

#define PC_FMU_NX (PC_NQ + PC_NV)
#define PC_FMU_NT (2 * PC_NV)
#define PC_FMU_NP1 (PC_NP > 0 ? PC_NP : 1)
#if PC_STEP_JACOBIAN
/* F (nt x nt), G (nt x np), H (nz x nt), Hp (nz x np), row-major, in this order */
#define PC_FMU_NJAC (PC_FMU_NT * PC_FMU_NT + PC_FMU_NT * PC_NP + PC_NZ * PC_FMU_NT + PC_NZ * PC_NP)
#else
#define PC_FMU_NJAC 1
#endif

enum { PC_FMU_OK = 0, PC_FMU_WARNING = 1, PC_FMU_DISCARD = 2, PC_FMU_ERROR = 3 };
enum { PC_MODE_INSTANTIATED = 0, PC_MODE_INIT = 1, PC_MODE_STEP = 2, PC_MODE_TERMINATED = 3, PC_MODE_ERROR = 4 };

/* Everything the FMU state holds: plain data, copied and serialised byte for byte. */
typedef struct {
    double time, last_ok_time;
    double x[PC_FMU_NX];
    double p[PC_FMU_NP1];
    double u[PC_NU];
    double xc[PC_FMU_NX];
    double reset, jreq;
    double jac[PC_FMU_NJAC];
    double sens[6];   /* gyro_mean, accel_mean over the last step (when sensed) */
    int jac_valid, mode;
    int sensed;       /* 1 once a step (or the lead) has been taken: sens holds its means */
} pc_fmu_state_t;

/* The wrapper's logger: status (an FMI status), category and the formatted message. */
typedef void (*pc_fmu_logger_t)(void* env, const char* instance, int status, const char* category, const char* message);

typedef struct {
    pc_fmu_state_t c;
    pc_fmu_state_t next; /* a setter's values until every one is accepted */
    pc_model_t* m;
    pc_data_t* d;
    char* name;
    pc_fmu_logger_t log;
    void* env;
    int logging, out_valid;
    double y[PC_NY], xdot[PC_FMU_NX], ddq[PC_NV];
    double scratch[PC_FMU_NJAC];                      /* the Jacobians of a step until it succeeds */
    double A[2 * PC_NV * PC_NV + PC_NV * (PC_NU + PC_FMU_NP1)]; /* continuous partials (directional) */
    char last_error[512];
} pc_fmu_t;

/* lifecycle: NULL (and a logged reason) when the plant cannot be created */
pc_fmu_t* pc_fmu_new(const char* function, const char* name, pc_fmu_logger_t log, void* env, int logging);
void pc_fmu_free(pc_fmu_t* F);
void pc_fmu_defaults(pc_fmu_t* F);
int pc_fmu_fail(pc_fmu_t* F, const char* function, const char* fmt, ...);
int pc_fmu_in_error(pc_fmu_t* F, const char* function);
int pc_fmu_start(pc_fmu_t* F, const char* function, double start_time);
int pc_fmu_exit_init(pc_fmu_t* F, const char* function);

/* values (Real / Float64) */
int pc_fmu_get(pc_fmu_t* F, const char* function, const unsigned* vr, size_t n, double* value);
int pc_fmu_set(pc_fmu_t* F, const char* function, const unsigned* vr, size_t n, const double* value);

/* a communication step from t of length H (any positive H: equal internal steps no longer than PC_STEP) */
int pc_fmu_do_step(pc_fmu_t* F, const char* function, double t, double H);

/* directional derivatives: knowns are states and inputs, unknowns state derivatives and outputs */
int pc_fmu_directional(pc_fmu_t* F, const char* function, const unsigned* unknown, size_t n_unknown,
                       const unsigned* known, size_t n_known, const double* seed, double* out);

/* FMU state */
int pc_fmu_get_state(pc_fmu_t* F, const char* function, void** state);
int pc_fmu_set_state(pc_fmu_t* F, const char* function, const void* state);
void pc_fmu_free_state(void** state);
size_t pc_fmu_serialized_size(void);
int pc_fmu_serialize(pc_fmu_t* F, const char* function, const void* state, char* bytes, size_t size);
int pc_fmu_deserialize(pc_fmu_t* F, const char* function, const char* bytes, size_t size, void** state);

#endif
