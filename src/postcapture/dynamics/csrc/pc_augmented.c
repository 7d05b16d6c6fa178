/*
 * postcapture engine: the augmented error-state EKF over its own plant instance, or over a plant that steps
 * outside (pc_aug_create_external, pc_aug_predict_given: an FMU behind the Python process model) with the same
 * equations after the step (estimation/augmented.py states the model). Error state:
 *   [ dx (n: the plant's tangent) | gyro bias (3) | accelerometer bias (3) | gyro calibration (0 or 9) |
 *     parameters estimated | parameters considered | clone of the chaser's attitude, velocity, rate (9) ].
 * Owns the prediction (the plant's step with the parameters of eta and its exact Jacobians,
 * Phi = [[F, G dp/deta], [0, I]] on the plant rows, the clone taken before the step, random-walk biases, the
 * model noise), the measurement models (star tracker, the gyro's mean rate with its calibration, the
 * accelerometer's mean specific force, the encoders), the correction (the plant's box-plus, the clone's), and
 * the recovery and re-initialisation of this filter.
 * state: [x (nx), gyro bias (3), accelerometer bias (3), calibration (n_cal), eta (n_eta), clone q (4, scalar
 * first), v (3), w (3), dt, t, P (N x N)].
 */
#include <stdlib.h>

#include "pc_filter_internal.h"
#include "pc_internal.h"

struct pc_aug {
    pc_book_t book;
    const pc_model_t* m;
    pc_data_t* d;
    int N, n, nx, nq, nv, np, n_eta, n_cal, n_arm, full_noise, n_spec, want_jac;
    int i_bg, i_ba, i_cal, i_eta, i_clone;
    int arm_v[PC_MAX_MEAS];
    double step, r_acc[3], sg, sa, n_orbit;
    int* spec;
    unsigned char* consider;
    double *p_nom, *q_noise, *eta_init, *P_init;
    /* the state (views into one array) */
    double *x, *bg, *ba, *cal, *eta, *cq, *cv, *cw, *dt, *t, *P;
    /* scratch */
    double *F, *Fp, *J, *GJ, *top, *p, *q1, *v1, *z, *H, *dx, *kf;
};

/* ------------------------------------------------------------------------------------ creation */
static size_t scratch_doubles(int N, int n, int np, int n_eta, int nq, int nv, int nz) {
    return (size_t)n * n + (size_t)n * np + (size_t)np * n_eta + (size_t)n * n_eta + (size_t)N * N + (size_t)np +
           (size_t)nq + (size_t)nv + (size_t)nz + (size_t)PC_MAX_MEAS * N + (size_t)N +
           pc_kf_workspace(N, PC_MAX_MEAS);
}

static void carve(pc_aug_t* f, double* mem, int nz) {
    int N = f->N, n = f->n;
    f->x = mem;
    f->bg = f->x + f->nx;
    f->ba = f->bg + 3;
    f->cal = f->ba + 3;
    f->eta = f->cal + f->n_cal;
    f->cq = f->eta + f->n_eta;
    f->cv = f->cq + 4;
    f->cw = f->cv + 3;
    f->dt = f->cw + 3;
    f->t = f->dt + 1;
    f->P = f->t + 1;
    f->book.state = mem;
    f->book.n_state = (size_t)(f->P + (size_t)N * N - mem);
    f->P_init = f->P + (size_t)N * N;
    f->eta_init = f->P_init + (size_t)N * N;
    f->p_nom = f->eta_init + f->n_eta;
    f->q_noise = f->p_nom + f->np;
    f->F = f->q_noise + (f->full_noise ? (size_t)n * n : (size_t)f->nv);
    f->Fp = f->F + (size_t)n * n;
    f->J = f->Fp + (size_t)n * f->np;
    f->GJ = f->J + (size_t)f->np * f->n_eta;
    f->top = f->GJ + (size_t)n * f->n_eta;
    f->p = f->top + (size_t)N * N;
    f->q1 = f->p + f->np;
    f->v1 = f->q1 + f->nq;
    f->z = f->v1 + f->nv;
    f->H = f->z + nz;
    f->dx = f->H + (size_t)PC_MAX_MEAS * N;
    f->kf = f->dx + N;
}

static void aug_recover(void* self, int kind);
static void aug_reinitialise(void* self);
static void take_clone(pc_aug_t* f);

static int check_config(int free_flyer, int nv, const pc_aug_config_t* c, int n_eta, int plant, char* err,
                        size_t n_err) {
    int i;
    if (!free_flyer || nv < 6) return pc_model_error(err, n_err, "the augmented EKF needs a free-flyer root");
    if (n_eta < 0) return pc_model_error(err, n_err, "parameter map: a block does not fit the plant's parameters");
    if (c->n_cal != 0 && c->n_cal != 9) return pc_model_error(err, n_err, "gyro calibration: 0 or 9 states");
    if (c->n_consider < 0 || c->n_consider > n_eta) return pc_model_error(err, n_err, "considered coordinates");
    if (c->n_arm < 0 || c->n_arm > PC_MAX_MEAS) return pc_model_error(err, n_err, "encoders: at most 32");
    for (i = 0; i < c->n_arm; i++)
        if (c->arm_v[i] < 6 || c->arm_v[i] >= nv) return pc_model_error(err, n_err, "encoder %d: no joint", i);
    if (plant && !(c->step > 0.0)) return pc_model_error(err, n_err, "the model step must be positive");
    return PC_OK;
}

/* the filter over a plant instance (m, d), or over none (m = d = NULL: a free-flyer root with nq, nv, np, whose
 * steps come from outside through pc_aug_predict_given) */
static pc_aug_t* create(const pc_model_t* m, pc_data_t* d, int free_flyer, int nq, int nv, int np, int nz,
                        const pc_aug_config_t* cfg, const double* x0, const double* eta0, const double* P0,
                        const double* q_noise, const pc_policy_t* policy, char* err, size_t err_size) {
    int n_eta = pc_parammap_size(cfg->param_spec, cfg->n_spec, np), n = 2 * nv, N, i;
    size_t n_state, total, nb = pc_book_doubles(policy);
    pc_aug_t* f;
    if (check_config(free_flyer, nv, cfg, n_eta, m != NULL, err, err_size)) return NULL;
    N = n + 6 + cfg->n_cal + n_eta + 9;
    n_state = (size_t)(nq + nv) + 6 + cfg->n_cal + n_eta + 10 + 2 + (size_t)N * N;
    total = n_state + (size_t)N * N + n_eta + np + (cfg->full_noise ? (size_t)n * n : (size_t)nv) +
            scratch_doubles(N, n, np, n_eta, nq, nv, nz) + nb + (size_t)cfg->n_spec + (size_t)N;
    f = (pc_aug_t*)calloc(1, sizeof(pc_aug_t) + total * sizeof(double));
    if (!f) {
        pc_model_error(err, err_size, "out of memory");
        return NULL;
    }
    if (pc_book_init(&f->book, policy, (double*)(f + 1) + total - nb - cfg->n_spec - N)) {
        free(f);
        pc_model_error(err, err_size, "recovery policy out of range");
        return NULL;
    }
    f->m = m;
    f->d = d;
    f->n = n;
    f->N = N;
    f->nq = nq;
    f->nv = nv;
    f->nx = nq + nv;
    f->np = np;
    f->n_eta = n_eta;
    f->n_cal = cfg->n_cal;
    f->n_arm = cfg->n_arm;
    f->full_noise = cfg->full_noise;
    f->want_jac = cfg->frozen_jacobian ? 2 : 1;
    f->i_bg = n;
    f->i_ba = n + 3;
    f->i_cal = n + 6;
    f->i_eta = n + 6 + cfg->n_cal;
    f->i_clone = f->i_eta + n_eta;
    for (i = 0; i < cfg->n_arm; i++) f->arm_v[i] = cfg->arm_v[i];
    f->step = cfg->step;
    for (i = 0; i < 3; i++) f->r_acc[i] = cfg->r_accel[i];
    f->sg = cfg->sigma_gyro_walk;
    f->sa = cfg->sigma_accel_walk;
    f->n_orbit = cfg->mean_motion;
    carve(f, (double*)(f + 1), nz);
    f->spec = (int*)(f->book.window_bound + f->book.n_window_bound + 1);
    f->n_spec = cfg->n_spec;
    memcpy(f->spec, cfg->param_spec, (size_t)cfg->n_spec * sizeof(int));
    f->consider = (unsigned char*)(f->spec + cfg->n_spec);
    for (i = 0; i < cfg->n_consider; i++) f->consider[f->i_clone - cfg->n_consider + i] = 1;
    memcpy(f->x, x0, (size_t)f->nx * sizeof(double));
    memcpy(f->eta, eta0, (size_t)n_eta * sizeof(double));
    memcpy(f->eta_init, eta0, (size_t)n_eta * sizeof(double));
    memcpy(f->P, P0, (size_t)N * N * sizeof(double));
    memcpy(f->P_init, P0, (size_t)N * N * sizeof(double));
    memcpy(f->p_nom, cfg->p_nominal, (size_t)np * sizeof(double));
    memcpy(f->q_noise, q_noise, (cfg->full_noise ? (size_t)n * n : (size_t)nv) * sizeof(double));
    take_clone(f);
    f->book.recover = aug_recover;
    f->book.reinitialise = aug_reinitialise;
    return f;
}

pc_aug_t* pc_aug_create(const pc_model_t* m, pc_data_t* d, const pc_aug_config_t* cfg, const double* x0,
                        const double* eta0, const double* P0, const double* q_noise, const pc_policy_t* policy,
                        char* err, size_t err_size) {
    if (!m || !d) {
        pc_model_error(err, err_size, "no plant instance: pc_aug_create_external takes the steps from outside");
        return NULL;
    }
    return create(m, d, m->free_flyer, m->nq, m->nv, m->np, m->nz, cfg, x0, eta0, P0, q_noise, policy, err, err_size);
}

pc_aug_t* pc_aug_create_external(int nq, int nv, int np, const pc_aug_config_t* cfg, const double* x0,
                                 const double* eta0, const double* P0, const double* q_noise,
                                 const pc_policy_t* policy, char* err, size_t err_size) {
    if (nv < 6 || nq != nv + 1 || np < 0) {
        pc_model_error(err, err_size, "sizes: expected a free-flyer root with Euclidean joints (nq = nv + 1, nv >= 6, "
                       "np >= 0), found nq = %d, nv = %d, np = %d", nq, nv, np);
        return NULL;
    }
    return create(NULL, NULL, 1, nq, nv, np, 0, cfg, x0, eta0, P0, q_noise, policy, err, err_size);
}

int pc_aug_sizes(const pc_aug_t* f, int* out) {
    out[0] = f->N;
    out[1] = f->n;
    out[2] = f->nx;
    out[3] = f->n_eta;
    out[4] = f->np;
    out[5] = f->n_cal;
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ prediction */
/* the chaser's attitude (scalar first), velocity and rate of the current state */
static void take_clone(pc_aug_t* f) {
    pc_q_from_xyzw(f->x + 3, f->cq);
    memcpy(f->cv, f->x + f->nq, 3 * sizeof(double));
    memcpy(f->cw, f->x + f->nq + 3, 3 * sizeof(double));
}

/* the plant's step over dt at the parameters of eta: q1, v1, F, Fp (and J = dp / deta) */
static int plant_step(pc_aug_t* f, double t, double dt) {
    int k = (int)lround(dt / f->step), err;
    pc_parammap_apply(f->spec, f->p_nom, f->np, f->eta, f->p, f->J);
    err = pc_set_params(f->m, f->d, f->p);
    if (err) {
        snprintf(f->book.message, sizeof f->book.message, "pc_set_params: %s", pc_error_message(f->d));
        return err;
    }
    memcpy(f->q1, f->x, (size_t)f->nq * sizeof(double));
    memcpy(f->v1, f->x + f->nq, (size_t)f->nv * sizeof(double));
    err = pc_predict(f->m, f->d, f->q1, f->v1, t, f->step, k, f->want_jac, f->z, f->F, NULL, f->Fp, NULL, NULL, NULL);
    if (err) snprintf(f->book.message, sizeof f->book.message, "pc_predict: %s", pc_error_message(f->d));
    return err;
}

/* P <- Phi P Phi^T with Phi = I but the plant rows [F, G J]; the cloned rows and columns copied first */
static void propagate(pc_aug_t* f) {
    int N = f->N, n = f->n, ne = f->n_eta, nv = f->nv, i, j, k;
    double *P = f->P, *T = f->top;
    const int a[9] = {3, 4, 5, nv, nv + 1, nv + 2, nv + 3, nv + 4, nv + 5};
    for (k = 0; k < 9; k++) memcpy(P + (size_t)(f->i_clone + k) * N, P + (size_t)a[k] * N, (size_t)N * sizeof(double));
    for (i = 0; i < N; i++)
        for (k = 0; k < 9; k++) P[(size_t)i * N + f->i_clone + k] = P[(size_t)i * N + a[k]];
    /* GJ = Fp J (n x n_eta) */
    for (i = 0; i < n; i++)
        for (j = 0; j < ne; j++) {
            double s = 0.0;
            for (k = 0; k < f->np; k++) s += f->Fp[(size_t)i * f->np + k] * f->J[(size_t)k * ne + j];
            f->GJ[(size_t)i * ne + j] = s;
        }
    /* top = F P[:n, :] + GJ P[eta, :] (n x N) */
    for (i = 0; i < n; i++) {
        double* Ti = T + (size_t)i * N;
        for (j = 0; j < N; j++) Ti[j] = 0.0;
        for (k = 0; k < n; k++) {
            double c = f->F[(size_t)i * n + k];
            const double* Pk = P + (size_t)k * N;
            if (c != 0.0)
                for (j = 0; j < N; j++) Ti[j] += c * Pk[j];
        }
        for (k = 0; k < ne; k++) {
            double c = f->GJ[(size_t)i * ne + k];
            const double* Pk = P + (size_t)(f->i_eta + k) * N;
            if (c != 0.0)
                for (j = 0; j < N; j++) Ti[j] += c * Pk[j];
        }
    }
    memcpy(P, T, (size_t)n * N * sizeof(double));
    /* left = P[:, :n] F^T + P[:, eta] GJ^T (N x n) */
    for (i = 0; i < N; i++) {
        const double* Pi = P + (size_t)i * N;
        double* Ti = T + (size_t)i * n;
        for (j = 0; j < n; j++) {
            double s = 0.0, r = 0.0;
            const double* Fj = f->F + (size_t)j * n;
            const double* Gj = f->GJ + (size_t)j * ne;
            for (k = 0; k < n; k++) s += Pi[k] * Fj[k];
            for (k = 0; k < ne; k++) r += Pi[f->i_eta + k] * Gj[k];
            Ti[j] = s + r;
        }
    }
    for (i = 0; i < N; i++) memcpy(P + (size_t)i * N, T + (size_t)i * n, (size_t)n * sizeof(double));
}

static void add_noise(pc_aug_t* f, double dt) {
    int N = f->N, n = f->n, nv = f->nv, i, j;
    double *P = f->P, g = f->sg * f->sg * dt, a = f->sa * f->sa * dt;
    if (f->full_noise) {
        for (i = 0; i < n; i++)
            for (j = 0; j < n; j++) P[(size_t)i * N + j] += f->q_noise[(size_t)i * n + j];
    } else {
        for (i = 0; i < nv; i++) P[(size_t)(nv + i) * N + nv + i] += f->q_noise[i];
    }
    for (i = 0; i < 3; i++) {
        P[(size_t)(f->i_bg + i) * N + f->i_bg + i] += g;
        P[(size_t)(f->i_ba + i) * N + f->i_ba + i] += a;
    }
    pc_symmetrize(P, N);
}

/* after the plant's step (q1, v1, F, Fp and J in place): the clone, P <- Phi P Phi^T + Q, the state, the check */
static int advance(pc_aug_t* f, double t, double dt) {
    take_clone(f);
    propagate(f);
    add_noise(f, dt);
    memcpy(f->x, f->q1, (size_t)f->nq * sizeof(double));
    memcpy(f->x + f->nq, f->v1, (size_t)f->nv * sizeof(double));
    *f->dt = dt;
    *f->t = t + dt;
    pc_book_check(&f->book, f->P, f->N, *f->t, 0);
    return PC_OK;
}

int pc_aug_predict(pc_aug_t* f, double t, double dt) {
    long k;
    int err;
    if (!f->m) {
        snprintf(f->book.message, sizeof f->book.message, "this filter has no plant instance: its steps come from "
                 "outside (pc_aug_predict_given)");
        return PC_ERR_ARG;
    }
    k = lround(dt / f->step);
    if (k < 1 || fabs(k * f->step - dt) > 1e-9 * (dt > 1.0 ? dt : 1.0)) {
        snprintf(f->book.message, sizeof f->book.message, "dt: expected a whole multiple of the model step %g, "
                 "found %g", f->step, dt);
        return PC_ERR_ARG;
    }
    err = plant_step(f, t, dt);
    if (err) { /* the plant copy cannot take this step with these values: diverge, start again from the prior */
        pc_book_diverge(&f->book, t, PC_CAUSE_PLANT, err, f->book.message);
        err = plant_step(f, t, dt);
        if (err) return err;
    }
    return advance(f, t, dt);
}

int pc_aug_plant_params(pc_aug_t* f, double* p, double* J) {
    pc_parammap_apply(f->spec, f->p_nom, f->np, f->eta, f->p, f->J);
    if (p) memcpy(p, f->p, (size_t)f->np * sizeof(double));
    if (J) memcpy(J, f->J, (size_t)f->np * f->n_eta * sizeof(double));
    return PC_OK;
}

int pc_aug_predict_given(pc_aug_t* f, double t, double dt, const double* x1, const double* F, const double* Fp) {
    size_t i, nF = (size_t)f->n * f->n, nG = (size_t)f->n * f->np;
    if (!(dt > 0.0) || !isfinite(dt) || !isfinite(t)) {
        snprintf(f->book.message, sizeof f->book.message, "t, dt: expected a finite time and a step > 0, found "
                 "t = %g, dt = %g", t, dt);
        return PC_ERR_ARG;
    }
    for (i = 0; i < (size_t)f->nx; i++)
        if (!isfinite(x1[i])) {
            snprintf(f->book.message, sizeof f->book.message, "the given step: x1[%d] is not finite", (int)i);
            return PC_ERR_ARG;
        }
    for (i = 0; i < nF; i++)
        if (!isfinite(F[i])) {
            snprintf(f->book.message, sizeof f->book.message, "the given step: F is not finite");
            return PC_ERR_ARG;
        }
    for (i = 0; i < nG; i++)
        if (!isfinite(Fp[i])) {
            snprintf(f->book.message, sizeof f->book.message, "the given step: Fp is not finite");
            return PC_ERR_ARG;
        }
    pc_parammap_apply(f->spec, f->p_nom, f->np, f->eta, f->p, f->J); /* J at the eta the step was taken with */
    memcpy(f->q1, x1, (size_t)f->nq * sizeof(double));
    memcpy(f->v1, x1 + f->nq, (size_t)f->nv * sizeof(double));
    memcpy(f->F, F, nF * sizeof(double));
    memcpy(f->Fp, Fp, nG * sizeof(double));
    return advance(f, t, dt);
}

void pc_aug_plant_failed(pc_aug_t* f, double t, int status, const char* text) {
    pc_book_diverge(&f->book, t, PC_CAUSE_PLANT, status, text);
}

/* ------------------------------------------------------------------------------------ measurements */
/* the gyro's mean rate: z (3), H (3 x N) */
static void gyro_model(pc_aug_t* f, double* z, double* H) {
    int N = f->N, i, j, k;
    double q1[4], w[3], H1[9], H0[9], C[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, D[27];
    pc_q_from_xyzw(f->x + 3, q1);
    pc_mean_rate(f->cq, q1, *f->dt, w, H1, H0, NULL);
    if (f->n_cal) {
        pc_triad_matrix(f->cal, C);
        pc_triad_sensitivity(w, D);
        for (i = 0; i < 3; i++)
            for (j = 0; j < 9; j++) H[(size_t)i * N + f->i_cal + j] = D[9 * i + j];
    }
    for (i = 0; i < 3; i++) {
        z[i] = 0.0;
        for (k = 0; k < 3; k++) z[i] += C[3 * i + k] * w[k];
        z[i] += f->bg[i];
        for (j = 0; j < 3; j++) {
            double a = 0.0, b = 0.0;
            for (k = 0; k < 3; k++) {
                a += C[3 * i + k] * H1[3 * k + j];
                b += C[3 * i + k] * H0[3 * k + j];
            }
            H[(size_t)i * N + 3 + j] = a;
            H[(size_t)i * N + f->i_clone + j] = b;
        }
        H[(size_t)i * N + f->i_bg + i] = 1.0;
    }
}

/* the accelerometer's mean specific force: z (3), H (3 x N) */
static void accelerometer_model(pc_aug_t* f, double* z, double* H) {
    int N = f->N, nv = f->nv, c = f->i_clone, i, j;
    double q1[4], phi[3], J[54];
    const int col[6] = {3, c, nv, nv + 3, c + 3, c + 6}; /* att1, att0, v1, w1, v0, w0 */
    pc_q_from_xyzw(f->x + 3, q1);
    pc_q_box_minus(q1, f->cq, phi);
    pc_mean_specific_force(phi, f->cv, f->cw, f->x + f->nq, f->x + f->nq + 3, f->r_acc, *f->dt, z, J);
    if (f->n_orbit != 0.0) { /* the reading is the acceleration less the tidal field (at the cycle's end position) */
        double g[3];
        pc_tidal_mean(f->cq, f->x, q1, f->x, f->r_acc, f->n_orbit, *f->t - *f->dt, *f->t, g);
        for (i = 0; i < 3; i++) z[i] -= g[i];
    }
    for (i = 0; i < 3; i++) {
        int b;
        for (b = 0; b < 6; b++)
            for (j = 0; j < 3; j++) H[(size_t)i * N + col[b] + j] = J[9 * b + 3 * i + j];
        H[(size_t)i * N + f->i_ba + i] = 1.0;
        z[i] += f->ba[i];
    }
}

/* the predicted measurement of a kind and its Jacobian (rows m x N, zeroed here); returns m */
static int measurement_model(pc_aug_t* f, int kind, double* z, double* H) {
    int N = f->N, i, m = kind == PC_KIND_ENCODERS ? f->n_arm : 3;
    memset(H, 0, (size_t)m * N * sizeof(double));
    if (kind == PC_KIND_GYRO) gyro_model(f, z, H);
    else if (kind == PC_KIND_ACCEL) accelerometer_model(f, z, H);
    else
        for (i = 0; i < m; i++) {
            z[i] = f->x[f->arm_v[i] + f->nq - f->nv];
            H[(size_t)i * N + f->arm_v[i]] = 1.0;
        }
    return m;
}

/* x <- x (+) dx: the plant's box-plus, the biases, calibration and coordinates, the clone's */
static void apply(pc_aug_t* f, const double* dx) {
    int i, c = f->i_clone;
    double q[4];
    pc_lie_integrate(f->nq, f->nv, 1, f->x, dx, f->q1); /* pc_integrate's: the root is a free flyer */
    memcpy(f->x, f->q1, (size_t)f->nq * sizeof(double));
    for (i = 0; i < f->nv; i++) f->x[f->nq + i] += dx[f->nv + i];
    for (i = 0; i < 3; i++) {
        f->bg[i] += dx[f->i_bg + i];
        f->ba[i] += dx[f->i_ba + i];
    }
    for (i = 0; i < f->n_cal; i++) f->cal[i] += dx[f->i_cal + i];
    for (i = 0; i < f->n_eta; i++) f->eta[i] += dx[f->i_eta + i];
    pc_q_box_plus(f->cq, dx + c, q);
    memcpy(f->cq, q, sizeof q);
    for (i = 0; i < 3; i++) {
        f->cv[i] += dx[c + 3 + i];
        f->cw[i] += dx[c + 6 + i];
    }
}

/* the innovation of a kind (NaN components of value left out, the star tracker's and gyro's whole sample
 * missing if any is): nu, H, R compressed to m rows; returns m, 0 when missing */
static int innovation(pc_aug_t* f, int kind, const double* value, const double* R_in, double* nu, double* R) {
    int N = f->N, i, j, m, k = 0, all = 1, rows[PC_MAX_MEAS];
    double z[PC_MAX_MEAS], q[4];
    m = kind == PC_KIND_STAR ? 4 : (kind == PC_KIND_ENCODERS ? f->n_arm : 3);
    for (i = 0; i < m; i++) all &= fabs(value[i]) < INFINITY;
    if (kind == PC_KIND_STAR) {
        if (!all) return 0;
        pc_q_from_xyzw(f->x + 3, q);
        pc_q_box_minus(value, q, nu);
        memset(f->H, 0, 3 * (size_t)N * sizeof(double));
        for (i = 0; i < 3; i++) f->H[(size_t)i * N + 3 + i] = 1.0;
        memcpy(R, R_in, 9 * sizeof(double));
        return 3;
    }
    if (kind == PC_KIND_GYRO && !all) return 0;
    measurement_model(f, kind, z, f->H);
    for (i = 0; i < m; i++) {
        if (!(fabs(value[i]) < INFINITY)) continue;
        rows[k] = i;
        nu[k] = value[i] - z[i];
        if (k != i) memcpy(f->H + (size_t)k * N, f->H + (size_t)i * N, (size_t)N * sizeof(double));
        k++;
    }
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++) R[i * k + j] = R_in[rows[i] * m + rows[j]];
    return k;
}

int pc_aug_measure(pc_aug_t* f, int kind, double* z, double* H) {
    if (kind < PC_KIND_GYRO || kind > PC_KIND_ENCODERS) return PC_ERR_ARG;
    measurement_model(f, kind, z, H);
    return PC_OK;
}

void pc_aug_apply(pc_aug_t* f, const double* dx) { apply(f, dx); }

int pc_aug_update(pc_aug_t* f, int kind, double t, const double* value, const double* R_in, pc_update_t* res) {
    double nu[PC_MAX_MEAS], R[PC_MAX_MEAS * PC_MAX_MEAS];
    int m, err;
    if (kind < 0 || kind > PC_KIND_ENCODERS) return PC_ERR_ARG;
    res->missing = 1;
    res->accepted = 0;
    m = innovation(f, kind, value, R_in, nu, R);
    if (!m) {
        pc_book_missing(&f->book);
        return PC_OK;
    }
    err = pc_kf_run(&f->book, kind, t, f->N, m, f->P, nu, f->H, R, f->consider, f->dx, NULL, res, f->kf);
    if (err) return err == PC_ERR_ARG ? err : PC_OK;
    if (res->accepted) apply(f, f->dx);
    pc_book_record(&f->book, kind, t, res->nis, m, res->accepted);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ outputs, recovery */
int pc_aug_parameters(pc_aug_t* f, double* p, double* C) {
    int np = f->np, ne = f->n_eta, N = f->N, i, j, k;
    pc_parammap_apply(f->spec, f->p_nom, np, f->eta, p, f->J);
    if (!C) return PC_OK;
    /* C = J P_eta J^T; GJ as scratch for J P_eta (np x ne) */
    for (i = 0; i < np; i++)
        for (j = 0; j < ne; j++) {
            double s = 0.0;
            for (k = 0; k < ne; k++) s += f->J[(size_t)i * ne + k] * f->P[(size_t)(f->i_eta + k) * N + f->i_eta + j];
            f->top[(size_t)i * ne + j] = s;
        }
    for (i = 0; i < np; i++)
        for (j = 0; j < np; j++) {
            double s = 0.0;
            for (k = 0; k < ne; k++) s += f->top[(size_t)i * ne + k] * f->J[(size_t)j * ne + k];
            C[(size_t)i * np + j] = s;
        }
    return PC_OK;
}

void pc_aug_reopen(pc_aug_t* f, int index, double sigma) {
    if (index >= 0 && index < f->N) f->P[(size_t)index * f->N + index] += sigma * sigma;
}

/* P <- P * outer(d, d) with d = sqrt(inflation) on what a kind of measurement informs, 1 elsewhere */
static void aug_recover(void* self, int kind) {
    pc_aug_t* f = (pc_aug_t*)self;
    int N = f->N, nv = f->nv, i, j;
    double *d = f->dx, s = sqrt(f->book.inflation), bump = f->book.gyro_bias_bump;
    for (i = 0; i < N; i++) d[i] = 1.0;
    if (kind == PC_KIND_STAR || kind == PC_KIND_GYRO) { /* the attitude (or rate) and the gyro bias */
        for (i = 0; i < 3; i++) d[(kind == PC_KIND_STAR ? 3 : nv + 3) + i] = d[f->i_bg + i] = s;
    } else if (kind == PC_KIND_ENCODERS) { /* the arm's angles and rates */
        for (i = 0; i < f->n_arm; i++) d[f->arm_v[i]] = d[f->arm_v[i] + nv] = s;
    } else { /* the accelerometer: the plant's velocities and its bias; a transient the model misses (a torque
              * step ringing the arm) is the state's to absorb, not a reason to forget the mass */
        for (i = nv; i < f->n; i++) d[i] = s;
        for (i = 0; i < 3; i++) d[f->i_ba + i] = s;
    }
    for (i = 0; i < N; i++)
        for (j = 0; j < N; j++) f->P[(size_t)i * N + j] *= d[i] * d[j];
    if (kind == PC_KIND_STAR || kind == PC_KIND_GYRO)
        for (i = 0; i < 3; i++) f->P[(size_t)(f->i_bg + i) * N + f->i_bg + i] += bump * bump;
}

/* back to the prior: the initial parameters and covariance, the biases kept, the state as it is */
static void aug_reinitialise(void* self) {
    pc_aug_t* f = (pc_aug_t*)self;
    memcpy(f->eta, f->eta_init, (size_t)f->n_eta * sizeof(double));
    memcpy(f->P, f->P_init, (size_t)f->N * f->N * sizeof(double));
}

void pc_aug_retune(pc_aug_t* f, const double* q_noise, double sigma_gyro_walk, double sigma_accel_walk) {
    memcpy(f->q_noise, q_noise, (f->full_noise ? (size_t)f->n * f->n : (size_t)f->nv) * sizeof(double));
    f->sg = sigma_gyro_walk;
    f->sa = sigma_accel_walk;
}
