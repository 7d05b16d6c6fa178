/*
 * postcapture estimator FMU: one cycle of the reference's dual scheme (estimation/dual.py; the cases
 * ekf_flexible and mekf_flexible) over the engine's filters, independent of the FMI version. As in the
 * reference, the predictor runs inside (the plant copy's step with its exact Jacobians, here the engine's)
 * and the corrector takes the inputs of that step:
 *
 *   1. the sigmoid mass filter predicts and its mass goes into the plant copy (the hub's, at a fixed centre
 *      of mass and inertia about it);
 *   2. the plant copy steps over [t, t + h] with F and the mass derivative g; the mass sensitivity S <- F S + g;
 *   3. ekf:  the attitude EKF propagates with the attitude block of F (plus the mass-aware noise when the
 *            case asks for it) and corrects the copy's attitude with the star tracker at t + h (S leans on it);
 *      mekf: the MEKF propagates with the last valid gyro sample and reads the star tracker; its attitude
 *            overwrites the copy's (S there is 0);
 *   4. the mass filter reads the accelerometer's mean specific force over the cycle and the encoders at its
 *      end against the copy's prediction, along the sensitivities (total) or through the step alone (partial);
 *   5. with the state shift, the copy moves onto the new mass's trajectory, x <- x (+) S d(theta).
 *
 * The equations between the filters and the copy are the engine's pc_refdual.c, which the Python scheme
 * calls too. Outputs: the attitude (the copy's with the EKF, the MEKF's), its 1-sigma, the MEKF's gyro bias,
 * the copy's body rate, the mass and its 1-sigma, the mass filter's accelerometer bias (realistic profile),
 * the NIS of the star tracker and of the mass filter's measurement (-1 when none), the recoveries and whether
 * a filter diverged. The reference's mass filter estimates the mass alone: no centre of mass or inertia.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_estimator.h"
#include "pc_filter_internal.h"

#define N_T (2 * PCE_NV)
#define N_Z (3 + PCE_NARM)
/* F, Fp, the copy's measurement z, H, Hp (asked for as the native model asks: they share the step's last stage) */
#define WORK (N_T * N_T + N_T * PCE_NP + PCE_NZ_PLANT * (1 + N_T + PCE_NP) + 1)
static const double REACQUIRE_ATTITUDE = 1.0;

int pc_est_create(pc_est_t* E, char* err, size_t n_err) {
    memset(E, 0, sizeof *E);
    E->m = pc_model_create(PCE_IB, PCE_DB, sizeof PCE_IB / sizeof PCE_IB[0], sizeof PCE_DB / sizeof PCE_DB[0],
                           PCE_STAGES, &PCE_TAB_A[0][0], PCE_TAB_B, PCE_TAB_C, err, n_err);
    E->d = E->m ? pc_data_create(E->m) : NULL;
    if (E->d && PCE_MEAN_MOTION != 0.0) pc_set_orbit(E->m, E->d, PCE_MEAN_MOTION); /* the filters model the orbit */
    E->work = E->d ? (double*)malloc(WORK * sizeof(double)) : NULL;
    if (!E->work) {
        if (E->m) snprintf(err, n_err, "out of memory");
        pc_data_destroy(E->d);
        pc_model_destroy(E->m);
        E->m = NULL;
        E->d = NULL;
        return PC_ERR_MEMORY;
    }
    pc_est_defaults(E);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ the plant copy */
static void attitude(const double* x, double* q) { pc_q_from_xyzw(x + 3, q); }

/* x <- x (+) dx (tangent: the configuration's right perturbation, then the velocities) */
static int retract(pc_est_t* E, double* x, const double* dx) {
    double q1[PCE_NQ];
    int i, err = pc_integrate(E->m, x, dx, q1);
    if (err) return err;
    memcpy(x, q1, sizeof q1);
    for (i = 0; i < PCE_NV; i++) x[PCE_NQ + i] += dx[PCE_NV + i];
    return PC_OK;
}

/* the plant copy's mass (its total: hub and panels) and the direction of its parameters in it */
static int set_mass(pc_est_t* E, double theta, double* dp) {
    double p[PCE_NP];
    int i, err;
    pc_get_params(E->m, E->d, p);
    if ((err = pc_target_mass(p, theta - PCE_PANEL_MASS, p))) {
        snprintf(E->message, sizeof E->message, "the mass estimate %.17g kg leaves no hub beside the panels' %g kg",
                 theta, PCE_PANEL_MASS);
        return err;
    }
    if ((err = pc_set_params(E->m, E->d, p))) {
        snprintf(E->message, sizeof E->message, "the plant copy refused its parameters: %s", pc_error_message(E->d));
        return err;
    }
    for (i = 0; i < PCE_NP; i++) dp[i] = 0.0;
    pc_dmass_direction(p, dp);
    return PC_OK;
}

/* one step of the copy from x: x1, F (n x n, in E->work) and g = d x1 / d mass (n) */
static int plant_step(pc_est_t* E, const double* x, double t, const double* dp, double* x1, double** F, double* g) {
    double *Fp = E->work + N_T * N_T, *z = Fp + N_T * PCE_NP, *H = z + PCE_NZ_PLANT, *Hp = H + PCE_NZ_PLANT * N_T;
    int i, j, err;
    *F = E->work;
    memcpy(x1, x, PCE_NX * sizeof(double));
    err = pc_predict(E->m, E->d, x1, x1 + PCE_NQ, t, PCE_STEP, PCE_NSTEPS, PCE_FROZEN_JACOBIAN ? 2 : 1, z, *F, NULL, Fp,
                     H, NULL, Hp);
    if (err) {
        snprintf(E->message, sizeof E->message, "the plant copy's step at t = %.17g s failed: %s", t,
                 pc_error_message(E->d));
        return err;
    }
    for (i = 0; i < N_T; i++) {
        double s = 0.0;
        for (j = 0; j < PCE_NP; j++) s += Fp[(size_t)i * PCE_NP + j] * dp[j];
        g[i] = s;
    }
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ outputs */
static void outputs(pc_est_t* E) {
    double* r = E->r;
    double q[4], theta, sigma, *P;
    long counts[PC_NCOUNTS], rec = 0, div = 0;
    int i;
    if (PCE_ATT_EKF) {
        attitude(E->x, q);
        P = pc_filter_state(E->atekf, NULL);
        for (i = 0; i < 3; i++) r[PCE_VR_ATT_SIGMA + i] = sqrt(P[4 * i]);
    } else {
        double* ms = pc_filter_state(E->mekf, NULL);
        for (i = 0; i < 4; i++) q[i] = ms[i];
        for (i = 0; i < 3; i++) r[PCE_VR_ATT_SIGMA + i] = sqrt(ms[PCE_MEKF_M + 2 + i * PCE_MEKF_M + i]);
#ifdef PCE_VR_GYRO_BIAS
        for (i = 0; i < 3; i++) r[PCE_VR_GYRO_BIAS + i] = ms[4 + i];
#endif
    }
    for (i = 0; i < 4; i++) r[PCE_VR_Q + i] = q[i];
    for (i = 0; i < 3; i++) r[PCE_VR_OMEGA + i] = E->x[PCE_NQ + 3 + i];
    pc_massf_estimate(E->massf, &theta, &sigma);
    r[PCE_VR_MASS] = theta;
    r[PCE_VR_MASS_SIGMA] = sigma;
#ifdef PCE_VR_ACCEL_BIAS
    for (i = 0; i < 3; i++) r[PCE_VR_ACCEL_BIAS + i] = pc_filter_state(E->massf, NULL)[1 + i];
#endif
    for (i = 0; i < 3; i++) {
        void* f = i == 0 ? (void*)E->atekf : (i == 1 ? (void*)E->mekf : (void*)E->massf);
        if (!f) continue;
        pc_filter_status(f, counts);
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
static void policy(pc_policy_t* p, const int* ints, const double* reals, const double* gate, const double* bound) {
    p->reject_limit = ints[0];
    p->nis_window = ints[1];
    p->max_recoveries = ints[2];
    p->gated = ints[3];
    p->n_gate = ints[4];
    p->n_window_bound = ints[5];
    p->inflation = reals[0];
    p->gyro_bias_bump = reals[1];
    p->recovery_window = reals[2];
    p->gate = gate;
    p->window_bound = bound;
}

#if PCE_ATT_EKF
static void ekf_Q(const pc_est_t* E, double* Q) {
    int i;
    for (i = 0; i < 9; i++) Q[i] = E->r[PCE_VR_EKF_Q + i];
}
#endif

static double mass_q_bias(const pc_est_t* E) {
#if PCE_MASS_NB
    return E->r[PCE_VR_MASS_Q_BIAS];
#else
    (void)E;
    return 0.0;
#endif
}

int pc_est_start(pc_est_t* E, double t0) {
    double q[4], xq[4], dx[N_T];
    double* r = E->r;
    pc_policy_t pol;
    int i, err;
    pc_est_free_filters(E);
    for (i = 0; i < 4; i++) q[i] = r[PCE_VR_Q0 + i];
    if (!pc_est_unit(q)) {
        snprintf(E->message, sizeof E->message, "q0_BN: expected a unit quaternion, found norm %.17g",
                 sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]));
        return PC_ERR_ARG;
    }
    /* the copy at the initial mass (the native copy's parameters), its attitude replaced by the initial estimate */
    if ((err = pc_set_params(E->m, E->d, PCE_P0))) {
        snprintf(E->message, sizeof E->message, "the plant copy refused its parameters: %s", pc_error_message(E->d));
        return err;
    }
    memcpy(E->x, PCE_X0, sizeof E->x);
    memcpy(E->S, PCE_S0, sizeof E->S);
    memset(dx, 0, sizeof dx);
    attitude(E->x, xq);
    pc_q_box_minus(q, xq, dx + 3);
    if ((err = retract(E, E->x, dx))) return err;
    policy(&pol, PCE_POL_ATT_I, PCE_POL_ATT_D, PCE_POL_ATT_GATE, PCE_POL_ATT_BOUND);
#if PCE_ATT_EKF
    {
        double Q[9];
        ekf_Q(E, Q);
        E->atekf = pc_atekf_create(PCE_EKF_P0, Q, REACQUIRE_ATTITUDE, &pol);
    }
#else
    attitude(E->x, xq);
    E->mekf = pc_mekf_create(PCE_MEKF_M, xq, NULL, PCE_MEKF_P0, t0, r[PCE_VR_MEKF_SIGMA_V], r[PCE_VR_MEKF_SIGMA_U],
                             REACQUIRE_ATTITUDE, PCE_MEKF_REACQUIRE_BIAS, &pol);
#endif
    policy(&pol, PCE_POL_MASS_I, PCE_POL_MASS_D, PCE_POL_MASS_GATE, PCE_POL_MASS_BOUND);
    E->massf = pc_massf_create(PCE_MASS_NB, PCE_MASS_X0, PCE_MASS_P0, PCE_MASS_P0_BIAS, r[PCE_VR_MASS_Q_START],
                               r[PCE_VR_MASS_Q_END], mass_q_bias(E), PCE_SIG_A, PCE_SIG_B, PCE_SIG_C, t0,
                               r[PCE_VR_MASS_T_END], &pol);
    if (!(E->atekf || E->mekf) || !E->massf) {
        snprintf(E->message, sizeof E->message, "the filters could not be created");
        pc_est_free_filters(E);
        return PC_ERR_MEMORY;
    }
    E->t = t0;
    E->k = 0;
    E->have_gyro = 0;
    E->started = 1;
    r[PCE_VR_NIS] = r[PCE_VR_NIS + 1] = -1.0;
    outputs(E);
    return PC_OK;
}

int pc_est_retune(pc_est_t* E) {
    if (!E->started) return PC_OK;
#if PCE_ATT_EKF
    {
        double Q[9];
        ekf_Q(E, Q);
        pc_atekf_retune(E->atekf, Q);
    }
#else
    pc_mekf_retune(E->mekf, E->r[PCE_VR_MEKF_SIGMA_V], E->r[PCE_VR_MEKF_SIGMA_U]);
#endif
    pc_massf_retune(E->massf, E->r[PCE_VR_MASS_Q_START], E->r[PCE_VR_MASS_Q_END], mass_q_bias(E));
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ one cycle */
/* a filter's failure in words (a failure of the copy has its own already) */
static int failed(pc_est_t* E, int err) {
    if (!E->message[0]) {
        const char* a = pc_filter_message(E->atekf ? (void*)E->atekf : (void*)E->mekf);
        const char* m = pc_filter_message(E->massf);
        snprintf(E->message, sizeof E->message, "%s%s", a && a[0] ? "the attitude filter: " : "the mass filter: ",
                 a && a[0] ? a : (m ? m : "failed"));
    }
    return err;
}

/* step 3 with the model-based EKF over the copy's step (x1, F, g): S_pred the sensitivity before the correction */
static int ekf_attitude(pc_est_t* E, double t, double h, double sigma, const double* star, const double* x1,
                        const double* F, const double* g, double* S_pred) {
    double Fa[9], Qm[9], dtheta[3], K[9], qe[4], dx[N_T];
    pc_update_t res;
    int i, j, err;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Fa[3 * i + j] = F[(size_t)(3 + i) * N_T + 3 + j];
    if (PCE_MASS_AWARE_Q) pc_rdual_mass_noise(E->S + PCE_NV + 3, h, sigma, Qm);
    if ((err = pc_atekf_predict(E->atekf, t + h, Fa, PCE_MASS_AWARE_Q ? Qm : NULL))) return err;
    pc_rdual_propagate(N_T, F, g, E->S, S_pred);
    memcpy(E->S, S_pred, sizeof E->S);
    memcpy(E->x, x1, sizeof E->x);
    attitude(E->x, qe);
    if ((err = pc_atekf_update(E->atekf, t + h, star, qe, E->r + PCE_VR_R_STAR, dtheta, K, &res))) return err;
    if (!res.missing && res.accepted) {
        E->r[PCE_VR_NIS] = res.nis;
        memset(dx, 0, sizeof dx);
        for (i = 0; i < 3; i++) dx[3 + i] = dtheta[i];
        if ((err = retract(E, E->x, dx))) return err;
        pc_rdual_lean(K, E->S + 3);
    }
    return PC_OK;
}

/* step 3 with the gyro-driven MEKF, whose attitude overwrites the copy's (x1, F, g: the copy's step) */
static int mekf_attitude(pc_est_t* E, double t, double h, const double* gyro, const double* star, const double* x1,
                         const double* F, const double* g, double* S_pred) {
    double qp[4], dx[N_T];
    pc_update_t res;
    int i, err;
    pc_rdual_propagate(N_T, F, g, E->S, S_pred);
    memcpy(E->S, S_pred, sizeof E->S);
    if (fabs(gyro[0]) < INFINITY && fabs(gyro[1]) < INFINITY && fabs(gyro[2]) < INFINITY) {
        memcpy(E->last_gyro, gyro, sizeof E->last_gyro);
        E->have_gyro = 1;
    }
    if (E->have_gyro && (err = pc_mekf_predict(E->mekf, t, h, E->last_gyro))) return err;
    if ((err = pc_mekf_update(E->mekf, t + h, star, E->r + PCE_VR_R_STAR, &res))) return err;
    if (!res.missing && res.accepted) E->r[PCE_VR_NIS] = res.nis;
    memset(dx, 0, sizeof dx);
    attitude(x1, qp);
    pc_q_box_minus(pc_filter_state(E->mekf, NULL), qp, dx + 3);
    for (i = 0; i < 3; i++) E->S[3 + i] = 0.0;
    memcpy(E->x, x1, sizeof E->x);
    return retract(E, E->x, dx);
}

/* the devices' prediction from the copy's states x0, x1 along the sensitivities s0, s1 (tangent, n) */
static void devices(const double* x0, const double* x1, const double* S0, const double* S1, double* z, double* dz) {
    double q0[4], q1[4], s0[9], s1[9], angles[PCE_NARM > 0 ? PCE_NARM : 1], s_arm[PCE_NARM > 0 ? PCE_NARM : 1];
    int i;
    attitude(x0, q0);
    attitude(x1, q1);
    for (i = 0; i < 3; i++) {
        s0[i] = S0[3 + i];
        s0[3 + i] = S0[PCE_NV + i];
        s0[6 + i] = S0[PCE_NV + 3 + i];
        s1[i] = S1[3 + i];
        s1[3 + i] = S1[PCE_NV + i];
        s1[6 + i] = S1[PCE_NV + 3 + i];
    }
    for (i = 0; i < PCE_NARM; i++) {
        angles[i] = x1[PCE_ARM_V[i] + PCE_NQ - PCE_NV];
        s_arm[i] = S1[PCE_ARM_V[i]];
    }
    pc_rdual_devices(q0, q1, x0 + PCE_NQ, x0 + PCE_NQ + 3, x1 + PCE_NQ, x1 + PCE_NQ + 3, PCE_R_ACC, PCE_DT, s0, s1,
                     PCE_NARM, angles, s_arm, z, dz);
}

/* steps 4-5: the mass from the cycle's increments and the encoders, then the copy onto the new mass's path */
static int correct_mass(pc_est_t* E, double t1, const double* x_start, const double* S_start, const double* x1,
                        const double* S_pred, const double* g, const double* accel, const double* enc) {
    double z[N_Z], dz[N_Z], nu[N_Z], R[N_Z * N_Z], zero[N_T], theta0, theta1, sigma, dx[N_T];
    pc_update_t res;
    int i, err;
    if (PCE_MASS_TOTAL) {
        devices(x_start, x1, S_start, S_pred, z, dz);
    } else {
        memset(zero, 0, sizeof zero);
        devices(x_start, x1, zero, g, z, dz); /* through this step alone */
    }
    for (i = 0; i < 3; i++) nu[i] = accel[i] - z[i];
    for (i = 0; i < PCE_NARM; i++) nu[3 + i] = enc[i] - z[3 + i];
    for (i = 0; i < N_Z * N_Z; i++) R[i] = 0.0;
    for (i = 0; i < N_Z; i++) R[i * N_Z + i] = E->r[PCE_VR_MASS_R + i];
    pc_massf_estimate(E->massf, &theta0, &sigma);
    if ((err = pc_massf_update(E->massf, t1, N_Z, nu, dz, R, &res))) return err;
    if (res.missing || !res.accepted) return PC_OK;
    E->r[PCE_VR_NIS + 1] = res.nis;
    if (PCE_SHIFT_STATE && PCE_MASS_TOTAL) {
        pc_massf_estimate(E->massf, &theta1, &sigma);
        for (i = 0; i < N_T; i++) dx[i] = E->S[i] * (theta1 - theta0);
        return retract(E, E->x, dx);
    }
    return PC_OK;
}

int pc_est_cycle(pc_est_t* E, double t, double h) {
    double star[4], gyro[3], accel[3], enc[PCE_NARM > 0 ? PCE_NARM : 1], dp[PCE_NP], theta, sigma;
    double x_start[PCE_NX], S_start[N_T], x1[PCE_NX], g[N_T], S_pred[N_T], *F;
    int err;
    E->message[0] = '\0';
    E->r[PCE_VR_NIS] = E->r[PCE_VR_NIS + 1] = -1.0; /* none (a master such as OMSimulator refuses NaN) */
    if ((err = pc_est_read_inputs(E, star, gyro, accel, enc))) return err;
    memcpy(x_start, E->x, sizeof x_start);
    memcpy(S_start, E->S, sizeof S_start);
    if ((err = pc_massf_predict(E->massf, t))) return failed(E, err);
    pc_massf_estimate(E->massf, &theta, &sigma);
    if ((err = set_mass(E, theta, dp))) return err;
    if ((err = plant_step(E, E->x, t, dp, x1, &F, g))) return err;
    err = PCE_ATT_EKF ? ekf_attitude(E, t, h, sigma, star, x1, F, g, S_pred)
                      : mekf_attitude(E, t, h, gyro, star, x1, F, g, S_pred);
    if (err) return failed(E, err);
    if ((err = correct_mass(E, t + h, x_start, S_start, x1, S_pred, g, accel, enc))) return failed(E, err);
    drain(E->atekf);
    drain(E->mekf);
    drain(E->massf);
    E->t = t + h;
    E->k++;
    outputs(E);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ state */
#define HEAD 6

size_t pc_est_state_size(const pc_est_t* E) {
    const void* att = E->atekf ? (const void*)E->atekf : (const void*)E->mekf;
    return HEAD + PCE_NREAL + PCE_NX + N_T + pc_filter_save_size(att) + pc_filter_save_size(E->massf);
}

void pc_est_save(const pc_est_t* E, double* o) {
    const void* att = E->atekf ? (const void*)E->atekf : (const void*)E->mekf;
    o[0] = E->t;
    o[1] = (double)E->k;
    o[2] = E->have_gyro;
    memcpy(o + 3, E->last_gyro, 3 * sizeof(double));
    memcpy(o + HEAD, E->r, sizeof E->r);
    o += HEAD + PCE_NREAL;
    memcpy(o, E->x, sizeof E->x);
    memcpy(o + PCE_NX, E->S, sizeof E->S);
    o += PCE_NX + N_T;
    pc_filter_save(att, o);
    pc_filter_save(E->massf, o + pc_filter_save_size(att));
}

/* the end of a filter's save is its state array (pc_filter_save) */
static const double* saved_state(void* f, const double* save, size_t* n) {
    pc_filter_state(f, n);
    return save + pc_filter_save_size(f) - *n;
}

int pc_est_load(pc_est_t* E, const double* o) {
    void* att = E->atekf ? (void*)E->atekf : (void*)E->mekf;
    const double* x = o + HEAD + PCE_NREAL;
    const double* a = x + PCE_NX + N_T;
    const double *as, *ms;
    size_t na = pc_filter_save_size(att), n;
    double xq[4];
    int i, finite = 1, nm = 1 + PCE_MASS_NB;
    xq[0] = x[6]; xq[1] = x[3]; xq[2] = x[4]; xq[3] = x[5];
    for (i = 0; i < PCE_NX + N_T; i++) finite &= fabs(x[i]) < INFINITY;
    if (!pc_est_unit(xq) || !finite) {
        snprintf(E->message, sizeof E->message, "the plant copy's state is not finite or its quaternion not unit");
        return PC_ERR_ARG;
    }
    as = saved_state(att, a, &n);
    if (E->mekf ? !pc_est_unit(as) || !pc_est_covariance(as + n - (size_t)PCE_MEKF_M * PCE_MEKF_M, PCE_MEKF_M)
                : !pc_est_covariance(as, 3)) {
        snprintf(E->message, sizeof E->message, "the attitude filter's quaternion is not unit or its covariance not "
                 "finite and symmetric");
        return PC_ERR_ARG;
    }
    ms = saved_state(E->massf, a + na, &n);
    if (!(fabs(ms[0]) < INFINITY) || !pc_est_covariance(ms + nm, nm)) {
        snprintf(E->message, sizeof E->message, "the mass filter's state is not finite or its covariance not "
                 "finite and symmetric");
        return PC_ERR_ARG;
    }
    E->t = o[0];
    E->k = (long)o[1];
    E->have_gyro = (int)o[2];
    memcpy(E->last_gyro, o + 3, 3 * sizeof(double));
    memcpy(E->r, o + HEAD, sizeof E->r);
    memcpy(E->x, x, sizeof E->x);
    memcpy(E->S, x + PCE_NX, sizeof E->S);
    pc_filter_load(att, a);
    pc_filter_load(E->massf, a + na);
    return pc_est_retune(E);
}
