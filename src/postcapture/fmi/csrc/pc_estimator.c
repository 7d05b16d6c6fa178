/*
 * postcapture estimator FMU: one cycle of a recommended scheme (estimation/schemes.py) over the engine's
 * filters, from the inputs sampled at that step, independent of the FMI version.
 *
 *   joint: the augmented EKF predicts over [t, t + h] (its plant copy: the engine's plant with the scenario's
 *          excitation plus the commanded inputs held over the step), then reads the gyro's mean rate and the
 *          accelerometer's mean specific force over the step and the star tracker and the encoders at its end;
 *   dual:  the MEKF predicts with the last valid gyro sample and reads the star tracker; the augmented EKF
 *          (its own gyro bias) predicts and reads the gyro, the accelerometer and the encoders.
 *
 * An input whose validity flag is 0 is missing; a non-finite component is missing and counted
 * (n_missing); a star-tracker quaternion whose norm is off 1 by more than star_norm_tolerance is refused
 * as an outlier (n_outliers). The outputs follow the native schemes' records: the attitude (the MEKF's in
 * dual), its 1-sigma, the gyro bias, the plant's rates, the parameter vector and the total target mass with
 * their 1-sigma (the discretisation's bias added as the native run adds it), the NIS per sensor of the
 * accepted updates (-1 when none: outputs stay finite), the recoveries and whether a filter diverged.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_estimator.h"
#include "pc_filter_internal.h"

static const double REACQUIRE_ATTITUDE = 1.0;

static void policy(pc_policy_t* p, int n_gate) {
    p->reject_limit = PCE_POL_REJECT;
    p->nis_window = PCE_POL_WINDOW;
    p->max_recoveries = PCE_POL_MAXREC;
    p->gated = PCE_GATED;
    p->n_gate = n_gate;
    p->n_window_bound = PCE_POL_WINDOW ? PCE_POL_WINDOW * n_gate + 1 : 1;
    p->inflation = PCE_POL_INFL;
    p->gyro_bias_bump = PCE_POL_BUMP;
    p->recovery_window = PCE_POL_RECWIN;
    p->gate = PCE_GATE;
    p->window_bound = PCE_WINDOW_BOUND;
}

int pc_est_create(pc_est_t* E, char* err, size_t n_err) {
    memset(E, 0, sizeof *E);
    E->m = pc_model_create(PCE_IB, PCE_DB, sizeof PCE_IB / sizeof PCE_IB[0], sizeof PCE_DB / sizeof PCE_DB[0],
                           PCE_STAGES, &PCE_TAB_A[0][0], PCE_TAB_B, PCE_TAB_C, err, n_err);
    E->d = E->m ? pc_data_create(E->m) : NULL;
    if (E->d && PCE_MEAN_MOTION != 0.0) pc_set_orbit(E->m, E->d, PCE_MEAN_MOTION); /* the filters model the orbit */
    if (!E->d) {
        if (E->m) snprintf(err, n_err, "out of memory");
        pc_model_destroy(E->m);
        E->m = NULL;
        return PC_ERR_MEMORY;
    }
    pc_est_defaults(E);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ outputs */
static void outputs(pc_est_t* E) {
    double* r = E->r;
    double p[PCE_NP], C[PCE_NP * PCE_NP], *st, q[4];
    long counts[PC_NCOUNTS], rec = 0, div = 0;
    int i, N = PCE_N;
    size_t n;
    st = pc_filter_state(E->aug, &n);
    pc_aug_parameters(E->aug, p, C);
    if (PCE_DUAL) {
        double* ms = pc_filter_state(E->mekf, NULL);
        for (i = 0; i < 4; i++) q[i] = ms[i];
        for (i = 0; i < 3; i++) {
            r[PCE_VR_ATT_SIGMA + i] = sqrt(ms[PCE_MEKF_M + 2 + i * PCE_MEKF_M + i]);
            r[PCE_VR_GYRO_BIAS + i] = ms[4 + i];
        }
    } else {
        const double* P = st + n - (size_t)N * N;
        q[0] = st[6]; q[1] = st[3]; q[2] = st[4]; q[3] = st[5];
        {
            double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), s = q[0] < 0.0 ? -1.0 : 1.0;
            for (i = 0; i < 4; i++) q[i] = s * q[i] / nq;
        }
        for (i = 0; i < 3; i++) {
            r[PCE_VR_ATT_SIGMA + i] = sqrt(P[(size_t)(3 + i) * N + 3 + i]);
            r[PCE_VR_GYRO_BIAS + i] = st[PCE_NX + i];
        }
    }
    for (i = 0; i < 4; i++) r[PCE_VR_Q + i] = q[i];
    for (i = 0; i < 3; i++) r[PCE_VR_OMEGA + i] = st[PCE_NQ + 3 + i];
    for (i = 0; i < PCE_NP; i++) {
        double v = C[i * PCE_NP + i] > 0.0 ? C[i * PCE_NP + i] : 0.0;
        if (E->k < PCE_NBIAS_T) v += PCE_BIAS[(size_t)i * PCE_NBIAS_T + E->k] * PCE_BIAS[(size_t)i * PCE_NBIAS_T + E->k];
        r[PCE_VR_P + i] = p[i];
        r[PCE_VR_P_SIGMA + i] = sqrt(v);
    }
    r[PCE_VR_MASS] = p[0] + PCE_PANEL_MASS;
    r[PCE_VR_MASS_SIGMA] = r[PCE_VR_P_SIGMA];
    pc_filter_status(E->aug, counts);
    rec += counts[PC_COUNT_RECOVERIES];
    div += counts[PC_COUNT_DIVERGENCES];
    if (E->mekf) {
        pc_filter_status(E->mekf, counts);
        rec += counts[PC_COUNT_RECOVERIES];
        div += counts[PC_COUNT_DIVERGENCES];
    }
    r[PCE_VR_RECOVERIES] = (double)rec;
    r[PCE_VR_DIVERGED] = div > 0 ? 1.0 : 0.0;
}

/* the events are the Python side's to word; here only their counts matter */
static void drain(void* f) {
    double ev[PC_EVD_SIZE * 8];
    char text[PC_EVENT_TEXT * 8];
    if (f)
        while (pc_filter_events(f, ev, text, 8) == 8) {
        }
}

/* ------------------------------------------------------------------------------------ start */
int pc_est_start(pc_est_t* E, double t0) {
    double x[PCE_NX], q[4], xq[4], d[2 * PCE_NV], x1[PCE_NX], qn[PCE_NV];
    double* r = E->r;
    pc_aug_config_t cfg;
    pc_policy_t pol;
    char err[256];
    int i;
    pc_est_free_filters(E);
    for (i = 0; i < 4; i++) q[i] = r[PCE_VR_Q0 + i];
    {
        double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (!(fabs(nq - 1.0) < 1e-6)) {
            snprintf(E->message, sizeof E->message, "q0_BN: expected a unit quaternion, found norm %.17g", nq);
            return PC_ERR_ARG;
        }
    }
    /* the prior's state with the initial attitude estimate, then moved to the prior's parameters */
    memcpy(x, PCE_X0, sizeof x);
    xq[0] = x[6]; xq[1] = x[3]; xq[2] = x[4]; xq[3] = x[5];
    pc_q_normalize(xq);
    memset(d, 0, sizeof d);
    pc_q_box_minus(q, xq, d + 3);
    pc_integrate(E->m, x, d, x1);
    memcpy(x, x1, PCE_NQ * sizeof(double));
    pc_integrate(E->m, x, PCE_DX0, x1);
    memcpy(x, x1, PCE_NQ * sizeof(double));
    for (i = 0; i < PCE_NV; i++) x[PCE_NQ + i] += PCE_DX0[PCE_NV + i];
    for (i = 0; i < PCE_NV; i++) qn[i] = r[PCE_VR_MODEL_NOISE + i];
    memset(&cfg, 0, sizeof cfg);
    cfg.n_arm = PCE_NARM;
    cfg.n_cal = PCE_NCAL;
    cfg.n_consider = PCE_NCON;
    cfg.full_noise = 0;
    cfg.frozen_jacobian = PCE_FROZEN_JACOBIAN;
    cfg.n_spec = PCE_NSPEC;
    cfg.arm_v = PCE_ARM_V;
    cfg.param_spec = PCE_SPEC;
    cfg.p_nominal = PCE_P_NOM;
    cfg.step = PCE_STEP;
    for (i = 0; i < 3; i++) cfg.r_accel[i] = PCE_R_ACC[i];
    cfg.sigma_gyro_walk = r[PCE_VR_SIGMA_GYRO_WALK];
    cfg.sigma_accel_walk = r[PCE_VR_SIGMA_ACCEL_WALK];
    cfg.mean_motion = PCE_MEAN_MOTION;
    policy(&pol, PCE_NARM > 3 ? PCE_NARM : 3);
    E->aug = pc_aug_create(E->m, E->d, &cfg, x, PCE_ETA0, PCE_P0, qn, &pol, err, sizeof err);
    if (!E->aug) {
        snprintf(E->message, sizeof E->message, "the augmented EKF: %s", err);
        return PC_ERR_MEMORY;
    }
    if (PCE_DUAL) {
        policy(&pol, 3);
        E->mekf = pc_mekf_create(PCE_MEKF_M, q, NULL, PCE_MEKF_P0, t0, r[PCE_VR_MEKF_SIGMA_V], r[PCE_VR_MEKF_SIGMA_U],
                                 REACQUIRE_ATTITUDE, PCE_MEKF_REACQUIRE_BIAS, &pol);
        if (!E->mekf) {
            snprintf(E->message, sizeof E->message, "the MEKF could not be created");
            return PC_ERR_MEMORY;
        }
    }
    E->t = t0;
    E->k = 0;
    E->have_gyro = 0;
    E->started = 1;
    for (i = 0; i < 4; i++) r[PCE_VR_NIS + i] = -1.0;
    outputs(E);
    return PC_OK;
}

int pc_est_retune(pc_est_t* E) {
    double qn[PCE_NV];
    int i;
    if (!E->started) return PC_OK;
    for (i = 0; i < PCE_NV; i++) qn[i] = E->r[PCE_VR_MODEL_NOISE + i];
    pc_aug_retune(E->aug, qn, E->r[PCE_VR_SIGMA_GYRO_WALK], E->r[PCE_VR_SIGMA_ACCEL_WALK]);
    if (E->mekf) pc_mekf_retune(E->mekf, E->r[PCE_VR_MEKF_SIGMA_V], E->r[PCE_VR_MEKF_SIGMA_U]);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ one cycle */
static void diag_R(double sigma, int n, double* R) {
    int i;
    for (i = 0; i < n * n; i++) R[i] = 0.0;
    for (i = 0; i < n; i++) R[i * n + i] = sigma * sigma;
}

static int aug_update(pc_est_t* E, int kind, double t1, const double* value, const double* R, int slot) {
    pc_update_t res;
    int err = pc_aug_update(E->aug, kind, t1, value, R, &res);
    if (!err && !res.missing && res.accepted) E->r[PCE_VR_NIS + slot] = res.nis;
    return err;
}

/* the dual's attitude filter: the MEKF on the last valid gyro sample, then the star tracker */
static int mekf_cycle(pc_est_t* E, double t, double h, const double* gyro, const double* star) {
    pc_update_t res;
    int err;
    if (fabs(gyro[0]) < INFINITY && fabs(gyro[1]) < INFINITY && fabs(gyro[2]) < INFINITY) {
        memcpy(E->last_gyro, gyro, sizeof E->last_gyro);
        E->have_gyro = 1;
    }
    if (E->have_gyro && (err = pc_mekf_predict(E->mekf, t, h, E->last_gyro))) return err;
    if ((err = pc_mekf_update(E->mekf, t + h, star, E->r + PCE_VR_R_STAR, &res))) return err;
    if (!res.missing && res.accepted) E->r[PCE_VR_NIS + 1] = res.nis;
    return PC_OK;
}

/* the augmented EKF's cycle: predict, then gyro, star tracker (joint), accelerometer, encoders */
static int aug_cycle(pc_est_t* E, double t, double h, const double* star, const double* gyro, const double* accel,
                     const double* enc) {
    double Rg[9], Ra[9], Re[PCE_NARM * PCE_NARM > 0 ? PCE_NARM * PCE_NARM : 1], t1 = t + h, *r = E->r;
    int err;
    diag_R(r[PCE_VR_SIGMA_GYRO], 3, Rg);
    diag_R(r[PCE_VR_SIGMA_ACCEL], 3, Ra);
    diag_R(r[PCE_VR_SIGMA_ENC], PCE_NARM, Re);
    if ((err = pc_aug_predict(E->aug, t, h))) return err;
    if ((err = aug_update(E, PC_KIND_GYRO, t1, gyro, Rg, 0))) return err;
    if (!PCE_DUAL && (err = aug_update(E, PC_KIND_STAR, t1, star, r + PCE_VR_R_STAR, 1))) return err;
    if ((err = aug_update(E, PC_KIND_ACCEL, t1, accel, Ra, 2))) return err;
    return aug_update(E, PC_KIND_ENCODERS, t1, enc, Re, 3);
}

int pc_est_cycle(pc_est_t* E, double t, double h) {
    double star[4], gyro[3], accel[3], enc[PCE_NARM > 0 ? PCE_NARM : 1];
    int i, err;
    for (i = 0; i < 4; i++) E->r[PCE_VR_NIS + i] = -1.0; /* none (a master such as OMSimulator refuses NaN) */
    if ((err = pc_est_read_inputs(E, star, gyro, accel, enc))) return err;
    if (PCE_DUAL && (err = mekf_cycle(E, t, h, gyro, star))) {
        snprintf(E->message, sizeof E->message, "the MEKF: %s", pc_filter_message(E->mekf));
        return err;
    }
    if ((err = aug_cycle(E, t, h, star, gyro, accel, enc))) {
        snprintf(E->message, sizeof E->message, "the augmented EKF: %s", pc_filter_message(E->aug));
        return err;
    }
    drain(E->aug);
    drain(E->mekf);
    E->t = t + h;
    E->k++;
    outputs(E);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ state */
#define HEAD 6

size_t pc_est_state_size(const pc_est_t* E) {
    return HEAD + PCE_NREAL + pc_filter_save_size(E->aug) + (E->mekf ? pc_filter_save_size(E->mekf) : 0);
}

void pc_est_save(const pc_est_t* E, double* o) {
    o[0] = E->t;
    o[1] = (double)E->k;
    o[2] = E->have_gyro;
    memcpy(o + 3, E->last_gyro, 3 * sizeof(double));
    memcpy(o + HEAD, E->r, sizeof E->r);
    o += HEAD + PCE_NREAL;
    pc_filter_save(E->aug, o);
    if (E->mekf) pc_filter_save(E->mekf, o + pc_filter_save_size(E->aug));
}

int pc_est_load(pc_est_t* E, const double* o) {
    size_t na = pc_filter_save_size(E->aug);
    const double* a = o + HEAD + PCE_NREAL;
    const double* st;
    size_t n_state;
    double q[4];
    int N = PCE_N;
    pc_filter_state(E->aug, &n_state);
    st = a + na - n_state; /* the state array ends the filter's save */
    q[0] = st[6]; q[1] = st[3]; q[2] = st[4]; q[3] = st[5];
    if (!pc_est_unit(q) || !pc_est_unit(st + PCE_NX + 6 + PCE_NCAL + PCE_NETA)) {
        snprintf(E->message, sizeof E->message, "the state's attitude or clone quaternion is not a unit quaternion");
        return PC_ERR_ARG;
    }
    if (!pc_est_covariance(st + n_state - (size_t)N * N, N)) {
        snprintf(E->message, sizeof E->message, "the state's covariance is not finite or not symmetric");
        return PC_ERR_ARG;
    }
    if (E->mekf) {
        size_t nm;
        const double* ms;
        pc_filter_state(E->mekf, &nm);
        ms = a + na + pc_filter_save_size(E->mekf) - nm;
        if (!pc_est_unit(ms)) {
            snprintf(E->message, sizeof E->message, "the state's MEKF quaternion is not a unit quaternion");
            return PC_ERR_ARG;
        }
        if (!pc_est_covariance(ms + nm - (size_t)PCE_MEKF_M * PCE_MEKF_M, PCE_MEKF_M)) {
            snprintf(E->message, sizeof E->message, "the state's MEKF covariance is not finite or not symmetric");
            return PC_ERR_ARG;
        }
    }
    E->t = o[0];
    E->k = (long)o[1];
    E->have_gyro = (int)o[2];
    memcpy(E->last_gyro, o + 3, 3 * sizeof(double));
    memcpy(E->r, o + HEAD, sizeof E->r);
    pc_filter_load(E->aug, a);
    if (E->mekf) pc_filter_load(E->mekf, a + na);
    return pc_est_retune(E);
}
