/*
 * postcapture engine: the reference's sigmoid-constrained mass filter (estimation/mass_filter.py). It
 * estimates x with theta = b + (a - b) / (1 + exp(-c x)) in (b, a), a random walk whose variance is
 * scheduled linearly over the run, and optionally the accelerometer's bias; it reads the linearised
 * accelerations (innovation and d z / d theta, NaN for a missing component).
 * state: [x, accelerometer bias (n_bias), P ((1 + n_bias)^2)].
 */
#include <stdlib.h>

#include "pc_filter_internal.h"

struct pc_massf {
    pc_book_t book;
    int nb, n;
    double q_start, q_end, q_bias, a, b, c, t0, t_end;
    double *s, *P, *P0, *ws;
};

static double expit(double y) { return y >= 0.0 ? 1.0 / (1.0 + exp(-y)) : exp(y) / (1.0 + exp(y)); }

void pc_sigmoid(double a, double b, double c, double x, double* theta, double* slope) {
    double cx = c * x;
    if (theta) *theta = b + (a - b) * expit(cx);
    if (slope) *slope = c * (a - b) * expit(cx) * expit(-cx);
}

static void massf_recover(void* self, int kind) {
    pc_massf_t* f = (pc_massf_t*)self;
    int i;
    (void)kind;
    for (i = 0; i < f->n * f->n; i++) f->P[i] *= f->book.inflation;
}

static void massf_reinitialise(void* self) {
    pc_massf_t* f = (pc_massf_t*)self;
    memcpy(f->P, f->P0, (size_t)f->n * f->n * sizeof(double));
}

pc_massf_t* pc_massf_create(int n_bias, double x0, double P0, double P0_bias, double q_start, double q_end,
                            double q_bias, double a, double b, double c, double t0, double t_end,
                            const pc_policy_t* policy) {
    int n = 1 + n_bias, i;
    size_t n_state = (size_t)n + (size_t)n * n, nb = pc_book_doubles(policy);
    size_t total = n_state + (size_t)n * n + pc_kf_workspace(n, PC_MAX_MEAS) + nb;
    pc_massf_t* f;
    if (n_bias != 0 && n_bias != 3) return NULL;
    f = (pc_massf_t*)calloc(1, sizeof(pc_massf_t) + total * sizeof(double));
    if (!f) return NULL;
    if (pc_book_init(&f->book, policy, (double*)(f + 1) + total - nb)) {
        free(f);
        return NULL;
    }
    f->nb = n_bias;
    f->n = n;
    f->q_start = q_start;
    f->q_end = q_end;
    f->q_bias = q_bias;
    f->a = a;
    f->b = b;
    f->c = c;
    f->t0 = t0;
    f->t_end = t_end;
    f->s = (double*)(f + 1);
    f->P = f->s + n;
    f->P0 = f->P + (size_t)n * n;
    f->ws = f->P0 + (size_t)n * n;
    f->s[0] = x0;
    f->P[0] = P0;
    for (i = 1; i < n; i++) f->P[i * n + i] = P0_bias;
    memcpy(f->P0, f->P, (size_t)n * n * sizeof(double));
    f->book.recover = massf_recover;
    f->book.reinitialise = massf_reinitialise;
    f->book.state = f->s;
    f->book.n_state = n_state;
    return f;
}

/* the variance added per step at t: linear from q_start to q_end over the run */
double pc_massf_noise(const pc_massf_t* f, double t) {
    double span = f->t_end - f->t0 > 1e-12 ? f->t_end - f->t0 : 1e-12, a = (t - f->t0) / span;
    a = a < 0.0 ? 0.0 : (a > 1.0 ? 1.0 : a);
    return f->q_start + a * (f->q_end - f->q_start);
}

/* the mass estimate and its 1-sigma through the map's slope */
void pc_massf_estimate(const pc_massf_t* f, double* theta, double* sigma) {
    double slope;
    pc_sigmoid(f->a, f->b, f->c, f->s[0], theta, &slope);
    *sigma = fabs(slope) * sqrt(f->P[0]);
}

/* new process noises: the schedule's ends and the bias's walk */
void pc_massf_retune(pc_massf_t* f, double q_start, double q_end, double q_bias) {
    f->q_start = q_start;
    f->q_end = q_end;
    f->q_bias = q_bias;
}

/* the scheduled variance at t, and the bias's walk */
int pc_massf_predict(pc_massf_t* f, double t) {
    int i;
    f->P[0] += pc_massf_noise(f, t);
    for (i = 1; i < f->n; i++) f->P[i * f->n + i] += f->q_bias;
    return PC_OK;
}

int pc_massf_update(pc_massf_t* f, double t, int m, const double* nu_in, const double* dz, const double* R,
                    pc_update_t* res) {
    int n = f->n, i, j, k = 0, err, rows[PC_MAX_MEAS];
    double nu[PC_MAX_MEAS], H[PC_MAX_MEAS * 4], Rr[PC_MAX_MEAS * PC_MAX_MEAS], dx[4], slope, limit;
    if (m < 1 || m > PC_MAX_MEAS) return PC_ERR_ARG;
    pc_sigmoid(f->a, f->b, f->c, f->s[0], NULL, &slope);
    for (i = 0; i < m; i++) {
        double v = nu_in[i] - (i < 3 && f->nb ? f->s[1 + i] : 0.0);
        if (!(fabs(v) < INFINITY && fabs(dz[i]) < INFINITY)) continue;
        rows[k] = i;
        nu[k] = v;
        for (j = 0; j < n; j++) H[k * n + j] = 0.0;
        H[k * n] = dz[i] * slope;
        if (f->nb && i < 3) H[k * n + 1 + i] = 1.0;
        k++;
    }
    res->missing = 1;
    res->accepted = 0;
    if (!k) {
        pc_book_missing(&f->book);
        return PC_OK;
    }
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++) Rr[i * k + j] = R[rows[i] * m + rows[j]];
    err = pc_kf_run(&f->book, PC_KIND_ACCELERATIONS, t, n, k, f->P, nu, H, Rr, NULL, dx, NULL, res, f->ws);
    if (err) return err == PC_ERR_ARG ? err : PC_OK;
    if (res->accepted) {
        for (i = 0; i < n; i++) f->s[i] += dx[i];
        /* keep the pre-image where the sigmoid is not flat in floating point (|c x| < 30) */
        limit = 30.0 / f->c;
        f->s[0] = f->s[0] < -limit ? -limit : (f->s[0] > limit ? limit : f->s[0]);
    }
    pc_book_record(&f->book, PC_KIND_ACCELERATIONS, t, res->nis, k, res->accepted);
    pc_book_check(&f->book, f->P, n, t, 1);
    return PC_OK;
}
