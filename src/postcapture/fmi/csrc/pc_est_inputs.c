/*
 * postcapture estimator FMU: what every scheme's cycle reads from the inputs (pc_estimator.h): the
 * measurements as the filters take them and the commanded inputs into the plant copy, and the checks of a
 * state a master sets; and the lifecycle both share (the filters a cycle created, the plant, the defaults).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_estimator.h"

/* an input sample as the filters read it: NaN when invalid; non-finite components counted as missing */
void pc_est_sample(pc_est_t* E, int vr, int n, int vr_valid, double* out) {
    int i, bad = 0, valid = E->r[vr_valid] > 0.5;
    for (i = 0; i < n; i++) {
        double v = E->r[vr + i];
        if (!(fabs(v) < INFINITY)) bad = 1;
        out[i] = valid && fabs(v) < INFINITY ? v : NAN;
    }
    if (valid && bad) E->r[PCE_VR_N_MISSING] += 1.0;
}

/* the cycle's inputs as the filters read them (a star-tracker quaternion off unit norm refused); the commanded
 * inputs into the plant copy */
int pc_est_read_inputs(pc_est_t* E, double* star, double* gyro, double* accel, double* enc) {
    double u[PCE_NU], *r = E->r;
    int i;
    pc_est_sample(E, PCE_VR_STAR, 4, PCE_VR_STAR_VALID, star);
    if (fabs(star[0]) < INFINITY) { /* a quaternion far from unit norm is not a star tracker's */
        double nq = sqrt(star[0] * star[0] + star[1] * star[1] + star[2] * star[2] + star[3] * star[3]);
        if (!(fabs(nq - 1.0) <= r[PCE_VR_STAR_NORM_TOL])) {
            for (i = 0; i < 4; i++) star[i] = NAN;
            r[PCE_VR_N_OUTLIERS] += 1.0;
        }
    }
    pc_est_sample(E, PCE_VR_GYRO, 3, PCE_VR_GYRO_VALID, gyro);
    pc_est_sample(E, PCE_VR_ACCEL, 3, PCE_VR_ACCEL_VALID, accel);
    pc_est_sample(E, PCE_VR_ENC, PCE_NARM, PCE_VR_ENC_VALID, enc);
    for (i = 0; i < PCE_NU; i++) {
        u[i] = r[PCE_VR_U + i];
        if (!(fabs(u[i]) < INFINITY)) {
            snprintf(E->message, sizeof E->message, "commanded input %d is not finite (%g)", i + 1, u[i]);
            return PC_ERR_ARG;
        }
    }
    return pc_set_input_offset(E->m, E->d, u);
}

/* a unit quaternion (|q| within 1e-6 of 1, finite) */
int pc_est_unit(const double* q) {
    double n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    return fabs(n) < INFINITY && fabs(sqrt(n) - 1.0) < 1e-6;
}

/* a covariance: finite, symmetric to round-off, non-negative diagonal */
int pc_est_covariance(const double* P, int n) {
    int i, j;
    for (i = 0; i < n; i++) {
        if (!(P[(size_t)i * n + i] >= 0.0) || !(P[(size_t)i * n + i] < INFINITY)) return 0;
        for (j = 0; j < i; j++) {
            double a = P[(size_t)i * n + j], b = P[(size_t)j * n + i];
            if (!(fabs(a) < INFINITY) || !(fabs(a - b) <= 1e-9 * (fabs(a) + fabs(b)) + 1e-300)) return 0;
        }
    }
    return 1;
}


/* the filters of whichever cycle created them */
void pc_est_free_filters(pc_est_t* E) {
    void* const filters[4] = {E->aug, E->mekf, E->atekf, E->massf};
    int i;
    for (i = 0; i < 4; i++)
        if (filters[i]) pc_filter_destroy(filters[i]);
    E->aug = NULL;
    E->mekf = NULL;
    E->atekf = NULL;
    E->massf = NULL;
    E->started = 0;
}

void pc_est_destroy(pc_est_t* E) {
    pc_est_free_filters(E);
    free(E->work);
    E->work = NULL;
    pc_data_destroy(E->d);
    pc_model_destroy(E->m);
}

void pc_est_defaults(pc_est_t* E) {
    int i;
    pc_est_free_filters(E);
    for (i = 0; i < PCE_NREAL; i++) E->r[i] = PCE_START[i];
    E->t = 0.0;
    E->k = 0;
    E->have_gyro = 0;
}
