/*
 * postcapture plant core: analytic partial derivatives of the inverse dynamics ID(q, v, a) = M a + b
 * with respect to q (tangent) and v, in the style of Pinocchio's computeRNEADerivatives (Carpentier and
 * Mansard, RSS 2018), in our own world-frame derivation. One forward and one backward pass, then two
 * 6-vector dot products per (row, column) pair on the column's subtree and ancestors: O(n d) with d the
 * tree's depth, instead of one tangent Newton-Euler pass per direction.
 *
 * In N, with J_j the world motion subspace of joint j, ov_k, oa_k, oI_k, h_k = oI_k ov_k and
 * of_k = oI_k oa_k + ov_k x* h_k per body, F_i, Ic_i and dYc_i the subtree sums of of_k, oI_k and
 * dY_k = [ov_k x*] oI_k - oI_k [ov_k x] + [. x* h_k], and for joint j with parent p:
 *   u = J_j x ov_p, e = J_j x oa_p - u x ov_p, c = ov_p x J_j - J_j x ov_j,
 * the partials of tau_i = J_i . F_i are
 *   d tau_i / d q_j = -(Ic_i J_i) . e - (dYc_i^T J_i) . u      (i in the subtree of j)
 *                   = J_i . (J_j x* F_j - Ic_j e - dYc_j u)    (i an ancestor of j)
 *   d tau_i / d v_j = (Ic_i J_i) . c + (dYc_i^T J_i) . J_j     (i in the subtree of j)
 *                   = J_i . (Ic_j c + dYc_j J_j)               (i an ancestor of j).
 * Without gravity the root's configuration does not enter ID (its q columns are zero).
 */
#include "pc_internal.h"

typedef struct {
    double *J, *P, *Q;     /* nv x 6: world motion subspace column of each velocity; Ic J, dYc^T J */
    double *ov, *oa, *F;   /* nj x 6 */
    double *Ic, *dY;       /* nj x 36: subtree inertia and inertia variation */
} rd_work_t;

static void skew(const double* a, double* S) {
    S[0] = 0; S[1] = -a[2]; S[2] = a[1]; S[3] = a[2]; S[4] = 0; S[5] = -a[0]; S[6] = -a[1]; S[7] = a[0]; S[8] = 0;
}

/* dY = [v x*] I - I [v x] + [. x* mu] for the inertia of dynamic parameters pi (m, h, I_O) and the
 * momentum mu = I v: with the skew matrices W = [w]x, L = [v_l]x, H = [h]x and mu_l = m v_l + w x h, its
 * linear columns vanish, the top-right block is -2 [mu_l]x and the bottom-right
 * W I_O - I_O W - L H - H L - [mu_n]x. */
static void inertia_variation(const double* pi, const double* v, const double* mu, double* dY) {
    double W[9], L[9], H[9], Io[9], A[9], B[9], C[9], D[9], Ml[9], Mn[9];
    int i, j;
    skew(v + 3, W);
    skew(v, L);
    skew(pi + 1, H);
    skew(mu, Ml);
    skew(mu + 3, Mn);
    Io[0] = pi[4]; Io[1] = Io[3] = pi[5]; Io[4] = pi[6]; Io[2] = Io[6] = pi[7]; Io[5] = Io[7] = pi[8]; Io[8] = pi[9];
    mm3(W, Io, A);
    mm3(Io, W, B);
    mm3(L, H, C);
    mm3(H, L, D);
    memset(dY, 0, 36 * sizeof(double));
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            dY[6 * i + 3 + j] = -2.0 * Ml[3 * i + j];
            dY[6 * (3 + i) + 3 + j] = A[3 * i + j] - B[3 * i + j] - C[3 * i + j] - D[3 * i + j] - Mn[3 * i + j];
        }
}

/* a body's ten dynamic parameters carried to the world frame by the placement (R, p) */
static void world_parameters(const double* R, const double* p, const double* pi, double* out) {
    double Io[9], T[9], Ir[9], h[3], P[9], Hh[9], PP[9], PH[9], HP[9], m = pi[0];
    int i, j;
    Io[0] = pi[4]; Io[1] = Io[3] = pi[5]; Io[4] = pi[6]; Io[2] = Io[6] = pi[7]; Io[5] = Io[7] = pi[8]; Io[8] = pi[9];
    mm3(R, Io, T);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Ir[3 * i + j] = T[3 * i] * R[3 * j] + T[3 * i + 1] * R[3 * j + 1] + T[3 * i + 2] * R[3 * j + 2];
    mv3(R, pi + 1, h);
    skew(p, P);
    skew(h, Hh);
    mm3(P, P, PP);
    mm3(P, Hh, PH);
    mm3(Hh, P, HP);
    for (i = 0; i < 9; i++) Ir[i] -= m * PP[i] + PH[i] + HP[i];
    out[0] = m;
    for (i = 0; i < 3; i++) out[1 + i] = h[i] + m * p[i];
    out[4] = Ir[0]; out[5] = Ir[1]; out[6] = Ir[4]; out[7] = Ir[2]; out[8] = Ir[5]; out[9] = Ir[8];
}

/* world motion subspace columns of joint i (world placements computed) */
static void joint_columns(const pc_model_t* m, const pc_data_t* d, int i, double* J) {
    const pc_joint_t* Jn = &m->joints[i];
    const double* R = d->Ro + 9 * i;
    const double* p = d->po + 3 * i;
    int a, k;
    if (Jn->kind >= 0) {
        double w[3] = {R[Jn->kind], R[3 + Jn->kind], R[6 + Jn->kind]};
        cross3(p, w, J);
        memcpy(J + 3, w, sizeof w);
        return;
    }
    for (a = 0; a < 6; a++) {
        double* Ja = J + 6 * a;
        double w[3] = {0, 0, 0};
        if (a < 3) {
            for (k = 0; k < 3; k++) Ja[k] = R[3 * k + a];
            memset(Ja + 3, 0, 3 * sizeof(double));
            continue;
        }
        for (k = 0; k < 3; k++) w[k] = R[3 * k + a - 3];
        cross3(p, w, Ja);
        memcpy(Ja + 3, w, sizeof w);
    }
}

/* forward pass: columns, twists, accelerations, body inertias, wrenches and inertia variations */
static void forward(const pc_model_t* m, pc_data_t* d, const double* v, const double* a, rd_work_t* W) {
    int i, k, c;
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* Jn = &m->joints[i];
        int nd = Jn->kind < 0 ? 6 : 1;
        double *J = W->J + 6 * Jn->iv, *ov = W->ov + 6 * i, *oa = W->oa + 6 * i, *I = W->Ic + 36 * i;
        double Sv[6] = {0, 0, 0, 0, 0, 0}, vS[6], pw[10], h[6], Ia[6], b[6];
        joint_columns(m, d, i, J);
        if (Jn->parent >= 0) {
            memcpy(ov, W->ov + 6 * Jn->parent, 6 * sizeof(double));
            memcpy(oa, W->oa + 6 * Jn->parent, 6 * sizeof(double));
        } else {
            memset(ov, 0, 6 * sizeof(double));
            memset(oa, 0, 6 * sizeof(double));
        }
        for (c = 0; c < nd; c++)
            for (k = 0; k < 6; k++) {
                Sv[k] += J[6 * c + k] * v[Jn->iv + c];
                oa[k] += J[6 * c + k] * a[Jn->iv + c];
            }
        for (k = 0; k < 6; k++) ov[k] += Sv[k];
        cross_motion(ov, Sv, vS);
        for (k = 0; k < 6; k++) oa[k] += vS[k];
        world_parameters(d->Ro + 9 * i, d->po + 3 * i, d->pi + 10 * i, pw);
        pc_joint_inertia_matrix(pw, I);
        inertia_mul(pw, ov, h);
        inertia_mul(pw, oa, Ia);
        cross_force(ov, h, b);
        for (k = 0; k < 6; k++) W->F[6 * i + k] = Ia[k] + b[k];
        inertia_variation(pw, ov, h, W->dY + 36 * i);
    }
}

/* backward pass: subtree sums, then P = Ic J and Q = dYc^T J per velocity */
static void backward(const pc_model_t* m, rd_work_t* W) {
    int i, k, c, r;
    for (i = m->nj - 1; i > 0; i--) {
        int p = m->joints[i].parent;
        if (p < 0) continue;
        for (k = 0; k < 6; k++) W->F[6 * p + k] += W->F[6 * i + k];
        for (k = 0; k < 36; k++) {
            W->Ic[36 * p + k] += W->Ic[36 * i + k];
            W->dY[36 * p + k] += W->dY[36 * i + k];
        }
    }
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* Jn = &m->joints[i];
        int nd = Jn->kind < 0 ? 6 : 1;
        for (c = 0; c < nd; c++) {
            const double* J = W->J + 6 * (Jn->iv + c);
            double* P = W->P + 6 * (Jn->iv + c);
            double* Q = W->Q + 6 * (Jn->iv + c);
            mv6(W->Ic + 36 * i, J, P);
            for (r = 0; r < 6; r++) {
                double s = 0.0;
                for (k = 0; k < 6; k++) s += W->dY[36 * i + 6 * k + r] * J[k];
                Q[r] = s;
            }
        }
    }
}

/* rows of joint i: out[row * nv + col] = dot(X_row, x) (+ dot(Y_row, y)) */
static void put_rows(const pc_model_t* m, int i, const double* X, const double* x, const double* Y, const double* y,
                     int col, double* out) {
    const pc_joint_t* Jn = &m->joints[i];
    int nd = Jn->kind < 0 ? 6 : 1, c;
    for (c = 0; c < nd; c++) {
        int row = Jn->iv + c;
        double s = dot6(X + 6 * row, x);
        if (Y) s += dot6(Y + 6 * row, y);
        out[(size_t)row * m->nv + col] = s;
    }
}

/* one revolute column j of dq and dv */
static void revolute_column(const pc_model_t* m, const rd_work_t* W, int j, double* dq, double* dv) {
    const pc_joint_t* Jn = &m->joints[j];
    const double zero[6] = {0, 0, 0, 0, 0, 0};
    const double* ovp = Jn->parent >= 0 ? W->ov + 6 * Jn->parent : zero;
    const double* oap = Jn->parent >= 0 ? W->oa + 6 * Jn->parent : zero;
    const double* J = W->J + 6 * Jn->iv;
    double u[6], e[6], z[6], c[6], t[6], G[6], H[6], nu[6], ne[6];
    int i, k, col = Jn->iv;
    cross_motion(J, ovp, u);
    cross_motion(J, oap, e);
    cross_motion(u, ovp, z);
    cross_motion(ovp, J, c);
    for (k = 0; k < 6; k++) { e[k] -= z[k]; c[k] *= 2.0; nu[k] = -u[k]; ne[k] = -e[k]; }
    for (i = j; i < m->sub_end[j]; i++) {
        if (dq) put_rows(m, i, W->P, ne, W->Q, nu, col, dq);
        if (dv) put_rows(m, i, W->P, c, W->Q, J, col, dv);
    }
    /* G = J x* F_j - Ic_j e - dYc_j u, H = Ic_j c + dYc_j J, dotted with the ancestors' columns */
    cross_force(J, W->F + 6 * j, G);
    mv6(W->Ic + 36 * j, e, t);
    for (k = 0; k < 6; k++) G[k] -= t[k];
    mv6(W->dY + 36 * j, u, t);
    for (k = 0; k < 6; k++) G[k] -= t[k];
    mv6(W->Ic + 36 * j, c, H);
    mv6(W->dY + 36 * j, J, t);
    for (k = 0; k < 6; k++) H[k] += t[k];
    for (i = Jn->parent; i >= 0; i = m->joints[i].parent) {
        if (dq) put_rows(m, i, W->J, G, NULL, NULL, col, dq);
        if (dv) put_rows(m, i, W->J, H, NULL, NULL, col, dv);
    }
}

/* the root's six dv columns: c = -J_a x ov_0, every joint in its subtree */
static void root_columns(const pc_model_t* m, const rd_work_t* W, double* dv) {
    int a, i, k;
    for (a = 0; a < 6; a++) {
        const double* J = W->J + 6 * a;
        double c[6];
        cross_motion(J, W->ov, c);
        for (k = 0; k < 6; k++) c[k] = -c[k];
        for (i = 0; i < m->nj; i++) put_rows(m, i, W->P, c, W->Q, J, a, dv);
    }
}

/* d ID / dq (tangent) and d ID / dv at (q, v, a), nv x nv row-major; either may be NULL. */
int pc_rnea_derivatives(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* a,
                        double* dq, double* dv) {
    size_t mark = PC_ARENA_MARK(d), nv = (size_t)m->nv, nj = (size_t)m->nj;
    double* buf = pc_arena_alloc(d, 18 * nv + 90 * nj);
    rd_work_t W;
    int j;
    if (!buf) return PC_ERR_MEMORY;
    W.J = buf; W.P = W.J + 6 * nv; W.Q = W.P + 6 * nv;
    W.ov = W.Q + 6 * nv; W.oa = W.ov + 6 * nj; W.F = W.oa + 6 * nj; W.Ic = W.F + 6 * nj; W.dY = W.Ic + 36 * nj;
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    forward(m, d, v, a, &W);
    backward(m, &W);
    if (dq) memset(dq, 0, nv * nv * sizeof(double));
    if (dv) memset(dv, 0, nv * nv * sizeof(double));
    for (j = 0; j < m->nj; j++) {
        if (m->joints[j].kind < 0) {
            if (dv) root_columns(m, &W, dv);
        } else {
            revolute_column(m, &W, j, dq, dv);
        }
    }
    PC_ARENA_RELEASE(d, mark);
    return PC_OK;
}
