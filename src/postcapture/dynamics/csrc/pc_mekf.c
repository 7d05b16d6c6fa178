/*
 * postcapture engine: the multiplicative EKF (Lefferts, Markley and Shuster 1982) for the attitude and the
 * gyro bias, and with 15 states the gyro's scale factors and misalignments (Markley and Crassidis 2014,
 * 6.4.1); estimation/mekf.py gives the equations. The gyro sample drives the propagation (closed-form
 * error transition at a rate held over the step), the star tracker corrects, and the correction is moved
 * into the attitude, bias and calibration (the reset).
 * state: [q (4), bias (3), calibration (m - 6), t, P (m x m)].
 */
#include <stdlib.h>

#include "pc_filter_internal.h"
#include "pc_internal.h"

struct pc_mekf {
    pc_book_t book;
    int m;
    double sigma_v, sigma_u, reacq_att, reacq_bias;
    double *q, *bias, *cal, *t, *P, *P0, *Q, *Phi, *ws;
    double Q_dt;
};

/* Phi6 (6 x 6) of the error over dt at the held rate w */
void pc_mekf_transition(const double* w, double dt, double* Phi) {
    double a2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], a = sqrt(a2), th = a * dt, W[9], W2[9], c1, c2, c3;
    int i, j;
    pc_skew(w, W);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) W2[3 * i + j] = w[i] * w[j] - (i == j ? a2 : 0.0);
    if (th < 1e-4) {
        c1 = dt * (1.0 - th * th / 6.0);
        c2 = dt * dt * (0.5 - th * th / 24.0);
        c3 = dt * dt * dt * (1.0 / 6.0 - th * th / 120.0);
    } else {
        double s = sin(th), c = cos(th);
        c1 = s / a;
        c2 = (1.0 - c) / a2;
        c3 = (th - s) / (a2 * a);
    }
    for (i = 0; i < 36; i++) Phi[i] = (i % 7 == 0) ? 1.0 : 0.0;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            Phi[6 * i + j] += c2 * W2[3 * i + j] - c1 * W[3 * i + j];
            Phi[6 * i + 3 + j] = c2 * W[3 * i + j] - c3 * W2[3 * i + j];
        }
    for (i = 0; i < 3; i++) Phi[6 * i + 3 + i] -= dt;
}

void pc_mekf_noise(double sigma_v, double sigma_u, double dt, double* Q6) {
    double su2 = sigma_u * sigma_u, q11 = sigma_v * sigma_v * dt + su2 * (dt * dt * dt) / 3.0;
    double q12 = -0.5 * su2 * (dt * dt), q22 = su2 * dt;
    int i;
    for (i = 0; i < 36; i++) Q6[i] = 0.0;
    for (i = 0; i < 3; i++) {
        Q6[6 * i + i] = q11;
        Q6[6 * i + 3 + i] = Q6[6 * (3 + i) + i] = q12;
        Q6[6 * (3 + i) + 3 + i] = q22;
    }
}

static void process_noise(pc_mekf_t* f, double dt) {
    int m = f->m, i, j;
    double Q6[36];
    if (f->Q_dt == dt) return;
    pc_mekf_noise(f->sigma_v, f->sigma_u, dt, Q6);
    memset(f->Q, 0, (size_t)m * m * sizeof(double));
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) f->Q[i * m + j] = Q6[6 * i + j];
    f->Q_dt = dt;
}

static void mekf_recover(void* self, int kind) {
    pc_mekf_t* f = (pc_mekf_t*)self;
    double d = sqrt(f->book.inflation), bump = f->book.gyro_bias_bump;
    int i, m = f->m;
    (void)kind;
    for (i = 0; i < m * m; i++) f->P[i] = f->P[i] * d * d;
    for (i = 3; i < 6; i++) f->P[i * m + i] += bump * bump;
}

static void mekf_reinitialise(void* self) {
    pc_mekf_t* f = (pc_mekf_t*)self;
    int i, m = f->m;
    memcpy(f->P, f->P0, (size_t)m * m * sizeof(double));
    for (i = 0; i < 3; i++) f->P[i * m + i] += f->reacq_att * f->reacq_att;
    for (i = 3; i < 6; i++) f->P[i * m + i] += f->reacq_bias * f->reacq_bias;
}

pc_mekf_t* pc_mekf_create(int m, const double* q0, const double* bias0, const double* P0, double t0, double sigma_v,
                          double sigma_u, double reacquire_attitude, double reacquire_bias, const pc_policy_t* policy) {
    size_t n_state, n_ws, total;
    pc_mekf_t* f;
    double* mem;
    if ((m != 6 && m != 15) || !policy) return NULL;
    n_state = 4 + 3 + (size_t)(m - 6) + 1 + (size_t)m * m;
    n_ws = pc_kf_workspace(m, 3) + 2 * (size_t)m * m;
    total = n_state + 3 * (size_t)m * m + n_ws + pc_book_doubles(policy);
    f = (pc_mekf_t*)calloc(1, sizeof(pc_mekf_t) + total * sizeof(double));
    if (!f) return NULL;
    mem = (double*)(f + 1);
    if (pc_book_init(&f->book, policy, mem + total - pc_book_doubles(policy))) {
        free(f);
        return NULL;
    }
    f->m = m;
    f->sigma_v = sigma_v;
    f->sigma_u = sigma_u;
    f->reacq_att = reacquire_attitude;
    f->reacq_bias = reacquire_bias;
    f->q = mem;
    f->bias = f->q + 4;
    f->cal = f->bias + 3;
    f->t = f->cal + (m - 6);
    f->P = f->t + 1;
    f->P0 = f->P + (size_t)m * m;
    f->Q = f->P0 + (size_t)m * m;
    f->Phi = f->Q + (size_t)m * m;
    f->ws = f->Phi + (size_t)m * m;
    f->Q_dt = -1.0;
    memcpy(f->q, q0, 4 * sizeof(double));
    pc_q_normalize(f->q);
    if (bias0) memcpy(f->bias, bias0, 3 * sizeof(double));
    *f->t = t0;
    memcpy(f->P, P0, (size_t)m * m * sizeof(double));
    pc_symmetrize(f->P, m);
    memcpy(f->P0, f->P, (size_t)m * m * sizeof(double));
    f->book.recover = mekf_recover;
    f->book.reinitialise = mekf_reinitialise;
    f->book.state = mem;
    f->book.n_state = n_state;
    return f;
}

int pc_mekf_predict(pc_mekf_t* f, double t, double dt, const double* u) {
    int m = f->m, i, j, piv[3];
    double w[3], d[3], Phi6[36], C[9], D[27];
    for (i = 0; i < 3; i++) {
        if (!(fabs(u[i]) < INFINITY)) {
            snprintf(f->book.message, sizeof f->book.message, "the gyro sample is not finite");
            return PC_ERR_ARG;
        }
        w[i] = u[i] - f->bias[i];
    }
    if (m == 15) {
        pc_triad_matrix(f->cal, C);
        if (pc_lu_factor(C, piv, 3)) {
            snprintf(f->book.message, sizeof f->book.message, "singular gyro calibration matrix");
            return PC_ERR_SINGULAR;
        }
        pc_lu_solve(C, piv, 3, w, 1, 1);
    }
    for (i = 0; i < 3; i++) d[i] = w[i] * dt;
    {
        double q1[4];
        pc_q_box_plus(f->q, d, q1);
        memcpy(f->q, q1, sizeof q1);
    }
    process_noise(f, dt);
    pc_mekf_transition(w, dt, Phi6);
    memset(f->Phi, 0, (size_t)m * m * sizeof(double));
    for (i = 0; i < m; i++) f->Phi[i * m + i] = 1.0;
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) f->Phi[i * m + j] = Phi6[6 * i + j];
    if (m == 15) { /* the attitude's column for the calibration: the bias column times D */
        int k;
        pc_triad_sensitivity(w, D);
        for (i = 0; i < 3; i++)
            for (j = 0; j < 9; j++) {
                double s = 0.0;
                for (k = 0; k < 3; k++) s += Phi6[6 * i + 3 + k] * D[9 * k + j];
                f->Phi[i * m + 6 + j] = s;
            }
    }
    pc_sym_predict(m, f->P, f->Phi, f->Q, f->ws);
    *f->t = t + dt;
    pc_book_check(&f->book, f->P, m, *f->t, 0);
    return PC_OK;
}

int pc_mekf_update(pc_mekf_t* f, double t, const double* q_meas, const double* R, pc_update_t* res) {
    int m = f->m, i, err;
    double nn = 0.0, nu[3], H[3 * 15], dx[15], q1[4];
    int finite = 1;
    for (i = 0; i < 4; i++) {
        finite &= fabs(q_meas[i]) < INFINITY;
        nn += q_meas[i] * q_meas[i];
    }
    res->missing = 1;
    res->accepted = 0;
    if (!finite || !(sqrt(nn) > 0.0)) {
        pc_book_missing(&f->book);
        return PC_OK;
    }
    pc_q_box_minus(q_meas, f->q, nu);
    memset(H, 0, sizeof H);
    for (i = 0; i < 3; i++) H[i * m + i] = 1.0;
    err = pc_kf_run(&f->book, PC_KIND_STAR, t, m, 3, f->P, nu, H, R, NULL, dx, NULL, res,
                    f->ws + 2 * (size_t)m * m);
    if (err) return err == PC_ERR_ARG ? err : PC_OK;
    if (res->accepted) {
        pc_q_box_plus(f->q, dx, q1);
        memcpy(f->q, q1, sizeof q1);
        for (i = 0; i < 3; i++) f->bias[i] += dx[3 + i];
        for (i = 6; i < m; i++) f->cal[i - 6] += dx[i];
    }
    pc_book_record(&f->book, PC_KIND_STAR, t, res->nis, 3, res->accepted);
    if (res->accepted) pc_book_check(&f->book, f->P, m, t, 1);
    return PC_OK;
}

void pc_mekf_retune(pc_mekf_t* f, double sigma_v, double sigma_u) {
    f->sigma_v = sigma_v;
    f->sigma_u = sigma_u;
    f->Q_dt = -1.0; /* the noise is computed again at the next step */
}
