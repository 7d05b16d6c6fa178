/*
 * postcapture estimator FMU: one filter cycle of an estimation scheme over the engine's filters, independent
 * of the FMI version (pc_est_fmi2.c wraps it): a recommended scheme (pc_estimator.c: joint, dual) or the
 * reference's dual scheme (pc_est_refdual.c: ekf_flexible, mekf_flexible), one of the two per FMU. The data
 * of one export (the plant's packed model, the filters' prior and tuning, the variables) come from the
 * generated pc_est_data.h; what both cycles read from the inputs is pc_est_inputs.c's.
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
    pc_atekf_t* atekf; /* the reference's dual: its attitude EKF (or the MEKF above) and its mass filter */
    pc_massf_t* massf;
    double x[PCE_NX], S[2 * PCE_NV]; /* ... their plant copy's state and its sensitivity to the mass */
    double* work;                    /* ... and its step's Jacobians (allocated once) */
    char message[512];
} pc_est_t;

int pc_est_create(pc_est_t* E, char* err, size_t n_err);
void pc_est_destroy(pc_est_t* E);  /* pc_est_inputs.c, as the two below */
void pc_est_defaults(pc_est_t* E);
void pc_est_free_filters(pc_est_t* E); /* the filters whichever cycle created */
int pc_est_start(pc_est_t* E, double t0);          /* the filters from the prior and the tunable settings */
int pc_est_cycle(pc_est_t* E, double t, double h); /* one filter cycle from t to t + h */
int pc_est_retune(pc_est_t* E);                     /* the tunable settings into the filters */
size_t pc_est_state_size(const pc_est_t* E);
void pc_est_save(const pc_est_t* E, double* buf);
int pc_est_load(pc_est_t* E, const double* buf); /* refuses a state with a bad quaternion or covariance */

/* pc_est_inputs.c: an input sample as the filters read it (NaN when its flag is off; a non-finite component
 * missing and counted in n_missing); the cycle's four measurements (a star-tracker quaternion off unit norm
 * refused as an outlier) with the commanded inputs set into the plant copy; a unit quaternion (within 1e-6,
 * finite); a covariance (finite, symmetric to round-off, non-negative diagonal) */
void pc_est_sample(pc_est_t* E, int vr, int n, int vr_valid, double* out);
int pc_est_read_inputs(pc_est_t* E, double* star, double* gyro, double* accel, double* enc);
int pc_est_unit(const double* q);
int pc_est_covariance(const double* P, int n);

#endif
