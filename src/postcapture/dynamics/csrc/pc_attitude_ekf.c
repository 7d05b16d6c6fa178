/*
 * postcapture engine: the model-based attitude EKF's arithmetic (estimation/attitude_ekf.py): an attitude
 * error (3, body frame) propagated by the attitude block of its plant copy's step Jacobian, corrected by
 * star-tracker quaternions through box_minus(q_meas, q_est) with H = I. The plant copy (any process model)
 * steps and takes the correction outside. state: [P (3 x 3)].
 */
#include <stdlib.h>

#include "pc_filter_internal.h"

struct pc_atekf {
    pc_book_t book;
    double P[9], P0[9], Q[9], reacq_att, ws[64 + 4 * 9 * 3 + 9];
};

static void atekf_recover(void* self, int kind) {
    pc_atekf_t* f = (pc_atekf_t*)self;
    int i;
    (void)kind;
    for (i = 0; i < 9; i++) f->P[i] *= f->book.inflation;
}

static void atekf_reinitialise(void* self) {
    pc_atekf_t* f = (pc_atekf_t*)self;
    int i;
    for (i = 0; i < 9; i++) f->P[i] = f->P0[i] + (i % 4 == 0 ? f->reacq_att * f->reacq_att : 0.0);
}

pc_atekf_t* pc_atekf_create(const double* P0, const double* Q, double reacquire_attitude, const pc_policy_t* policy) {
    size_t nb = pc_book_doubles(policy);
    pc_atekf_t* f = (pc_atekf_t*)calloc(1, sizeof(pc_atekf_t) + nb * sizeof(double));
    if (!f) return NULL;
    if (pc_book_init(&f->book, policy, (double*)(f + 1))) {
        free(f);
        return NULL;
    }
    memcpy(f->P, P0, sizeof f->P);
    memcpy(f->P0, P0, sizeof f->P0);
    memcpy(f->Q, Q, sizeof f->Q);
    f->reacq_att = reacquire_attitude;
    f->book.recover = atekf_recover;
    f->book.reinitialise = atekf_reinitialise;
    f->book.state = f->P;
    f->book.n_state = 9;
    return f;
}

void pc_atekf_retune(pc_atekf_t* f, const double* Q) { memcpy(f->Q, Q, sizeof f->Q); }

/* P <- sym(Fa P Fa^T + Q (+ Q_extra)); t: the prediction's end */
int pc_atekf_predict(pc_atekf_t* f, double t, const double* Fa, const double* Q_extra) {
    double Q[9];
    int i;
    for (i = 0; i < 9; i++) Q[i] = Q_extra ? f->Q[i] + Q_extra[i] : f->Q[i];
    pc_sym_predict(3, f->P, Fa, Q, f->ws);
    pc_book_check(&f->book, f->P, 3, t, 0);
    return PC_OK;
}

/* the star tracker's q_meas against the estimate q_est: dtheta (the correction, zero unless accepted), K */
int pc_atekf_update(pc_atekf_t* f, double t, const double* q_meas, const double* q_est, const double* R,
                    double* dtheta, double* K, pc_update_t* res) {
    static const double H[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double nu[3];
    int i, err, finite = 1;
    for (i = 0; i < 3; i++) dtheta[i] = 0.0;
    for (i = 0; i < 9; i++) K[i] = 0.0;
    for (i = 0; i < 4; i++) finite &= fabs(q_meas[i]) < INFINITY;
    res->missing = 1;
    res->accepted = 0;
    if (!finite) {
        pc_book_missing(&f->book);
        return PC_OK;
    }
    pc_q_box_minus(q_meas, q_est, nu);
    err = pc_kf_run(&f->book, PC_KIND_STAR, t, 3, 3, f->P, nu, H, R, NULL, dtheta, K, res, f->ws);
    if (err) return err == PC_ERR_ARG ? err : PC_OK;
    if (!res->accepted)
        for (i = 0; i < 9; i++) K[i] = 0.0;
    pc_book_record(&f->book, PC_KIND_STAR, t, res->nis, 3, res->accepted);
    return PC_OK;
}
