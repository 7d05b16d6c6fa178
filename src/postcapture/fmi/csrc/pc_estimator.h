/*
 * postcapture estimator FMU: one filter cycle of a recommended scheme over the engine's filters, independent
 * of the FMI version (pc_est_fmi2.c wraps it). The data of one export (the plant's packed model, the
 * filters' prior and tuning, the variables) come from the generated pc_est_data.h.
 */
#ifndef PC_ESTIMATOR_H
#define PC_ESTIMATOR_H

#include "pc_est_data.h"
#include "pc_filter.h"

#define PCE_NX (PCE_NQ + PCE_NV)

/* Everything a master may set, the scheme's own counters and the outputs: one array of reals, indexed by the
 * value references of pc_est_data.h (PCE_VR_*); the filters' state lives in the filters. */
typedef struct {
    double r[PCE_NREAL];
    double t;               /* time of the estimates (s) */
    long k;                 /* cycles done */
    int started, have_gyro; /* have_gyro: a valid gyro sample seen (the MEKF's input is held from it) */
    double last_gyro[3];
    pc_model_t* m;
    pc_data_t* d;
    pc_aug_t* aug;
    pc_mekf_t* mekf;
    char message[512];
} pc_est_t;

int pc_est_create(pc_est_t* E, char* err, size_t n_err);
void pc_est_destroy(pc_est_t* E);
void pc_est_defaults(pc_est_t* E);
int pc_est_start(pc_est_t* E, double t0);          /* the filters from the prior and the tunable settings */
int pc_est_cycle(pc_est_t* E, double t, double h); /* one filter cycle from t to t + h */
int pc_est_retune(pc_est_t* E);                     /* the tunable settings into the filters */
size_t pc_est_state_size(const pc_est_t* E);
void pc_est_save(const pc_est_t* E, double* buf);
int pc_est_load(pc_est_t* E, const double* buf); /* refuses a state with a bad quaternion or covariance */

#endif
