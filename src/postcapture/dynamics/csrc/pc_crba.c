/*
 * postcapture plant core: the composite-rigid-body algorithm. Owns the joint-space mass matrix M(q)
 * and the two spatial-inertia operations the recursions share: a body's 6x6 inertia from its ten
 * dynamic parameters, and a child's inertia carried into its parent's frame.
 */
#include "pc_internal.h"

void pc_joint_inertia_matrix(const double* pi, double* I6) {
    double m = pi[0], hx = pi[1], hy = pi[2], hz = pi[3];
    memset(I6, 0, 36 * sizeof(double));
    I6[0] = I6[7] = I6[14] = m;
    /* top-right -[h]x, bottom-left [h]x */
    I6[4] = hz; I6[5] = -hy; I6[9] = -hz; I6[11] = hx; I6[15] = hy; I6[16] = -hx;
    I6[19] = -hz; I6[20] = hy; I6[24] = hz; I6[26] = -hx; I6[30] = -hy; I6[31] = hx;
    I6[21] = pi[4]; I6[22] = pi[5]; I6[23] = pi[7];
    I6[27] = pi[5]; I6[28] = pi[6]; I6[29] = pi[8];
    I6[33] = pi[7]; I6[34] = pi[8]; I6[35] = pi[9];
}

static void rotate_block(const double* R, const double* X, double* out) { /* R X R^T */
    double T[9];
    int i, j;
    mm3(R, X, T);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) out[3 * i + j] = T[3 * i] * R[3 * j] + T[3 * i + 1] * R[3 * j + 1] + T[3 * i + 2] * R[3 * j + 2];
}

/* I_parent += X* Ia X^-1 for a child placed at (R, p): rotate the blocks, then shift by p. */
void pc_add_transformed_inertia(const double* R, const double* p, const double* Ia, double* Ip) {
    double A[9], B[9], C[9], Ar[9], Br[9], Cr[9], P[9], AP[9], PA[9], PB[9], X[9];
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            A[3 * i + j] = Ia[6 * i + j];
            B[3 * i + j] = Ia[6 * i + 3 + j];
            C[3 * i + j] = Ia[6 * (3 + i) + 3 + j];
        }
    rotate_block(R, A, Ar);
    rotate_block(R, B, Br);
    rotate_block(R, C, Cr);
    P[0] = 0; P[1] = -p[2]; P[2] = p[1]; P[3] = p[2]; P[4] = 0; P[5] = -p[0]; P[6] = -p[1]; P[7] = p[0]; P[8] = 0;
    mm3(Ar, P, AP);
    mm3(P, Ar, PA);
    mm3(P, Br, PB);
    /* X = P A + B^T (bottom-left block) */
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) X[3 * i + j] = PA[3 * i + j] + Br[3 * j + i];
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            double tr = Br[3 * i + j] - AP[3 * i + j];
            double br = PB[3 * i + j] + Cr[3 * i + j] - (X[3 * i] * P[j] + X[3 * i + 1] * P[3 + j] + X[3 * i + 2] * P[6 + j]);
            Ip[6 * i + j] += Ar[3 * i + j];
            Ip[6 * i + 3 + j] += tr;
            Ip[6 * (3 + i) + j] += X[3 * i + j];
            Ip[6 * (3 + i) + 3 + j] += br;
        }
}

/* column col of M: the composite inertia's wrench F carried from joint i to the root */
static void crba_column(const pc_model_t* m, const pc_data_t* d, int i, int col, double* F, double* M) {
    int cur = i, r, nv = m->nv;
    double up[6];
    while (cur >= 0) {
        const pc_joint_t* C = &m->joints[cur];
        if (C->kind < 0)
            for (r = 0; r < 6; r++) M[(size_t)(C->iv + r) * nv + col] = F[r];
        else
            M[(size_t)C->iv * nv + col] = F[3 + C->kind];
        if (C->parent >= 0) {
            force_act(d->Rl + 9 * cur, d->pl + 3 * cur, F, up);
            memcpy(F, up, sizeof up);
        }
        cur = C->parent;
    }
}

/* The joint-space mass matrix by the composite-rigid-body algorithm, nv x nv row-major. */
int pc_crba(const pc_model_t* m, pc_data_t* d, const double* q, double* M) {
    int nv = m->nv, i, k, r;
    pc_kinematics(m, d, q);
    memset(M, 0, (size_t)nv * nv * sizeof(double));
    for (i = 0; i < m->nj; i++) pc_joint_inertia_matrix(d->pi + 10 * i, d->IA + 36 * i);
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        const double* Ic = d->IA + 36 * i;
        int ncol = J->kind < 0 ? 6 : 1;
        for (k = 0; k < ncol; k++) {
            double F[6];
            for (r = 0; r < 6; r++) F[r] = Ic[6 * r + (J->kind < 0 ? k : 3 + J->kind)];
            crba_column(m, d, i, J->iv + k, F, M);
        }
        if (J->parent >= 0) pc_add_transformed_inertia(d->Rl + 9 * i, d->pl + 3 * i, Ic, d->IA + 36 * J->parent);
    }
    for (i = 0; i < nv; i++)
        for (k = 0; k < i; k++) M[(size_t)i * nv + k] = M[(size_t)k * nv + i];
    return PC_OK;
}

int pc_mass_matrix(const pc_model_t* m, pc_data_t* d, const double* q, double* M) { return pc_crba(m, d, q, M); }
