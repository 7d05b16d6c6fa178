/*
 * postcapture plant core: inputs, springs, kinematics, Featherstone's articulated-body algorithm, the
 * recursive Newton-Euler algorithm, the joint-space factorization used by the implicit integrators,
 * the configuration group, the measurement and the sampled outputs.
 */
#include <stdlib.h>

#include "pc_internal.h"

/* ------------------------------------------------------------------------------------ inputs */
/* The only implementation of the excitation profiles: the model's inputs (pc_inputs) and the Python
 * InputSchedule (pc_inputs_eval) both evaluate them here. */
void pc_profile_unpack(const int* ip, const double* dp, pc_profile_t* P) {
    P->kind = ip[0]; P->channel = ip[1]; P->table = ip[2]; P->n_table = ip[3];
    P->start = dp[0]; P->stop = dp[1]; P->a = dp[2]; P->rise = dp[3]; P->w = dp[4]; P->phase = dp[5];
    P->offset = dp[6]; P->f0 = dp[7]; P->rate = dp[8];
}

static double profile_value(const pc_profile_t* P, const double* table_t, const double* table_v, double t, int left) {
    int on = left ? (P->start < t && t <= P->stop) : (P->start <= t && t < P->stop);
    if (!on) return 0.0;
    switch (P->kind) {
        case PC_PROFILE_STEP: {
            double r;
            if (P->rise == 0.0) return P->a;
            r = fmin(1.0, (t - P->start) / P->rise);
            return P->a * fmin(r, (P->stop - t) / P->rise);
        }
        case PC_PROFILE_SINE:
            return P->offset + P->a * sin(P->w * (t - P->start) + P->phase);
        case PC_PROFILE_CHIRP: {
            double tau = t - P->start;
            return P->a * sin(2.0 * 3.141592653589793 * (P->f0 * tau + 0.5 * P->rate * tau * tau) + P->phase);
        }
        case PC_PROFILE_TABLE: {
            const double* ts = table_t + P->table;
            const double* vs = table_v + P->table;
            int n = P->n_table, j;
            if (t <= ts[0]) return vs[0];
            if (t >= ts[n - 1]) return vs[n - 1];
            for (j = 0; j < n - 2 && !(t < ts[j + 1]); j++) {
            }
            return vs[j] + (vs[j + 1] - vs[j]) * ((t - ts[j]) / (ts[j + 1] - ts[j]));
        }
    }
    return 0.0;
}

void pc_inputs(const pc_model_t* m, double t, int left, double* u) {
    int i;
    for (i = 0; i < m->nu; i++) u[i] = 0.0;
    for (i = 0; i < m->nprof; i++)
        u[m->prof[i].channel] += profile_value(&m->prof[i], m->table_t, m->table_v, t, left);
    for (i = 0; i < m->nu; i++) u[i] += m->u_extra[i];
}

int pc_inputs_eval(int nprof, const int* prof_i, const double* prof_d, int ntable, const double* table_t,
                   const double* table_v, int nu, int n_times, const double* t, int left, double* u_out) {
    int i, k;
    size_t n;
    if (nprof < 0 || ntable < 0 || nu < 0 || n_times < 0) return PC_ERR_ARG;
    for (i = 0; i < nprof; i++) { /* the packed layout as pack_profiles writes it, checked before any use */
        pc_profile_t P;
        pc_profile_unpack(prof_i + 4 * (size_t)i, prof_d + 9 * (size_t)i, &P);
        if (P.kind < PC_PROFILE_STEP || P.kind > PC_PROFILE_TABLE || P.channel < 0 || P.channel >= nu) return PC_ERR_ARG;
        if (P.kind == PC_PROFILE_TABLE && (P.n_table < 2 || P.table < 0 || P.table > ntable - P.n_table)) return PC_ERR_ARG;
    }
    for (n = 0; n < (size_t)n_times * (size_t)nu; n++) u_out[n] = 0.0;
    for (i = 0; i < nprof; i++) {
        pc_profile_t P;
        pc_profile_unpack(prof_i + 4 * (size_t)i, prof_d + 9 * (size_t)i, &P);
        for (k = 0; k < n_times; k++)
            u_out[(size_t)k * nu + P.channel] += profile_value(&P, table_t, table_v, t[k], left);
    }
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ forces */
void pc_spring_force(const pc_model_t* m, const double* q, const double* v, double* tau, int add) {
    int i, off = m->nq - m->nv;
    if (!add) memset(tau, 0, (size_t)m->nv * sizeof(double));
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        double defl = S->a[0] * q[S->v[0] + off] - S->rest, rate = S->a[0] * v[S->v[0]], f;
        if (S->v[1] >= 0) {
            defl += S->a[1] * q[S->v[1] + off];
            rate += S->a[1] * v[S->v[1]];
        }
        f = -S->k * defl - S->d * rate;
        tau[S->v[0]] += S->a[0] * f;
        if (S->v[1] >= 0) tau[S->v[1]] += S->a[1] * f;
    }
}

void pc_force(const pc_model_t* m, const double* q, const double* v, const double* u, double* tau) {
    int i, j;
    pc_spring_force(m, q, v, tau, 0);
    if (m->custom_b) {
        for (i = 0; i < m->nv; i++)
            for (j = 0; j < m->nu; j++) tau[i] += m->B[(size_t)i * m->nu + j] * u[j];
    } else {
        for (j = 0; j < m->nu; j++)
            if (m->u_to_v[j] >= 0) tau[m->u_to_v[j]] += u[j];
    }
}

/* ------------------------------------------------------------------------------------ kinematics */
void pc_kinematics(pc_model_t* m, const double* q) {
    int i;
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* R = m->Rl + 9 * i;
        double* p = m->pl + 3 * i;
        double Rq[9], t[3];
        if (J->kind < 0) {
            quat_to_matrix(q + J->iq + 3, Rq);
            mm3(J->R, Rq, R);
            mv3(J->R, q + J->iq, t);
            p[0] = J->p[0] + t[0]; p[1] = J->p[1] + t[1]; p[2] = J->p[2] + t[2];
        } else {
            axis_rotation(J->kind, q[J->iq], Rq);
            m->csl[2 * i] = Rq[4 * ((J->kind + 1) % 3)];
            m->csl[2 * i + 1] = Rq[3 * ((J->kind + 2) % 3) + (J->kind + 1) % 3];
            if (J->axis_only) memcpy(R, Rq, sizeof Rq);
            else mm3(J->R, Rq, R);
            p[0] = J->p[0]; p[1] = J->p[1]; p[2] = J->p[2];
        }
    }
}

void pc_world_placements(pc_model_t* m) {
    int i;
    for (i = 0; i < m->nj; i++) {
        int par = m->joints[i].parent;
        double* Ro = m->Ro + 9 * i;
        double* po = m->po + 3 * i;
        if (par < 0) {
            memcpy(Ro, m->Rl + 9 * i, 9 * sizeof(double));
            memcpy(po, m->pl + 3 * i, 3 * sizeof(double));
        } else {
            double t[3];
            mm3(m->Ro + 9 * par, m->Rl + 9 * i, Ro);
            mv3(m->Ro + 9 * par, m->pl + 3 * i, t);
            po[0] = m->po[3 * par] + t[0]; po[1] = m->po[3 * par + 1] + t[1]; po[2] = m->po[3 * par + 2] + t[2];
        }
    }
}

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

/* I_parent += X* Ia X^-1 for a child placed at (R, p): rotate the blocks, then shift by p. */
void pc_add_transformed_inertia(const double* R, const double* p, const double* Ia, double* Ip) {
    double A[9], B[9], C[9], T[9], Ar[9], Br[9], Cr[9], P[9], AP[9], PA[9], PB[9], X[9];
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            A[3 * i + j] = Ia[6 * i + j];
            B[3 * i + j] = Ia[6 * i + 3 + j];
            C[3 * i + j] = Ia[6 * (3 + i) + 3 + j];
        }
    /* Ar = R A R^T etc. */
    mm3(R, A, T);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Ar[3 * i + j] = T[3 * i] * R[3 * j] + T[3 * i + 1] * R[3 * j + 1] + T[3 * i + 2] * R[3 * j + 2];
    mm3(R, B, T);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Br[3 * i + j] = T[3 * i] * R[3 * j] + T[3 * i + 1] * R[3 * j + 1] + T[3 * i + 2] * R[3 * j + 2];
    mm3(R, C, T);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Cr[3 * i + j] = T[3 * i] * R[3 * j] + T[3 * i + 1] * R[3 * j + 1] + T[3 * i + 2] * R[3 * j + 2];
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

/* 6x6 symmetric positive definite: Cholesky in place (lower), then solve. */
static int chol6(double* A) {
    int i, j, k;
    for (j = 0; j < 6; j++) {
        double s = A[6 * j + j];
        for (k = 0; k < j; k++) s -= A[6 * j + k] * A[6 * j + k];
        if (!(s > 0.0)) return 1;
        A[6 * j + j] = sqrt(s);
        for (i = j + 1; i < 6; i++) {
            double t = A[6 * i + j];
            for (k = 0; k < j; k++) t -= A[6 * i + k] * A[6 * j + k];
            A[6 * i + j] = t / A[6 * j + j];
        }
    }
    return 0;
}

static void chol6_solve(const double* L, double* x) {
    int i, k;
    for (i = 0; i < 6; i++) {
        double s = x[i];
        for (k = 0; k < i; k++) s -= L[6 * i + k] * x[k];
        x[i] = s / L[6 * i + i];
    }
    for (i = 5; i >= 0; i--) {
        double s = x[i];
        for (k = i + 1; k < 6; k++) s -= L[6 * k + i] * x[k];
        x[i] = s / L[6 * i + i];
    }
}

/* ------------------------------------------------------------------------------------ ABA */
int pc_aba(pc_model_t* m, const double* q, const double* v, const double* tau, double* ddq) {
    int i, k;
    pc_kinematics(m, q);
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* vi = m->vj + 6 * i;
        double* ci = m->cj + 6 * i;
        double Iv[6];
        if (J->kind < 0) {
            memcpy(vi, v + J->iv, 6 * sizeof(double));
            memset(ci, 0, 6 * sizeof(double));
        } else {
            double vJ[6] = {0, 0, 0, 0, 0, 0};
            if (J->parent >= 0) PC_MOTION_INV(m, m->Rl, m->pl, m->csl, i, m->vj + 6 * J->parent, vi);
            else memset(vi, 0, 6 * sizeof(double));
            vJ[3 + J->kind] = v[J->iv];
            vi[3 + J->kind] += v[J->iv];
            cross_motion(vi, vJ, ci);
        }
        pc_joint_inertia_matrix(J->pi, m->IA + 36 * i);
        inertia_mul(J->pi, vi, Iv);
        cross_force(vi, Iv, m->fj + 6 * i); /* bias force pA */
    }
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* IA = m->IA + 36 * i;
        double* pA = m->fj + 6 * i;
        if (J->kind < 0) continue;
        {
            int a = 3 + J->kind;
            double* U = m->Uj + 6 * i;
            double D, u;
            for (k = 0; k < 6; k++) U[k] = IA[6 * k + a];
            D = U[a];
            u = tau[J->iv] - pA[a];
            m->Dj[i] = D;
            m->uj[i] = u;
            if (J->parent >= 0) {
                double Ia[36], pa[6], Ic[6], f[6];
                int r, c;
                for (r = 0; r < 6; r++)
                    for (c = 0; c < 6; c++) Ia[6 * r + c] = IA[6 * r + c] - U[r] * U[c] / D;
                mv6(Ia, m->cj + 6 * i, Ic);
                for (k = 0; k < 6; k++) pa[k] = pA[k] + Ic[k] + U[k] * (u / D);
                pc_add_transformed_inertia(m->Rl + 9 * i, m->pl + 3 * i, Ia, m->IA + 36 * J->parent);
                PC_FORCE_ACT(m, m->Rl, m->pl, m->csl, i, pa, f);
                for (k = 0; k < 6; k++) m->fj[6 * J->parent + k] += f[k];
            }
        }
    }
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* ai = m->aj + 6 * i;
        if (J->kind < 0) {
            double L[36];
            memcpy(L, m->IA, sizeof L);
            for (k = 0; k < 6; k++) ai[k] = tau[J->iv + k] - m->fj[k];
            if (chol6(L)) {
                pc_set_error(m, "articulated inertia of the root is not positive definite");
                return PC_ERR_SINGULAR;
            }
            chol6_solve(L, ai);
            memcpy(ddq + J->iv, ai, 6 * sizeof(double));
        } else {
            double x;
            if (J->parent >= 0) PC_MOTION_INV(m, m->Rl, m->pl, m->csl, i, m->aj + 6 * J->parent, ai);
            else memset(ai, 0, 6 * sizeof(double));
            for (k = 0; k < 6; k++) ai[k] += m->cj[6 * i + k];
            x = (m->uj[i] - dot6(m->Uj + 6 * i, ai)) / m->Dj[i];
            ddq[J->iv] = x;
            ai[3 + J->kind] += x;
        }
    }
    return PC_OK;
}

int pc_accel(pc_model_t* m, const double* q, const double* v, const double* u, double* ddq) {
    double* tau = m->tmp_nv[7];
    pc_force(m, q, v, u, tau);
    return pc_aba(m, q, v, tau, ddq);
}

/* ------------------------------------------------------------------------------------ RNEA */
/* Inverse dynamics tau = M(q) a + b(q, v); leaves v_i, a_i, f_i (subtree wrenches) in the workspace. */
int pc_rnea(pc_model_t* m, const double* q, const double* v, const double* a, double* tau) {
    int i, k;
    pc_kinematics(m, q);
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* vi = m->vj + 6 * i;
        double* ai = m->aj + 6 * i;
        double Iv[6], Ia[6], b[6];
        if (J->kind < 0) {
            memcpy(vi, v + J->iv, 6 * sizeof(double));
            memcpy(ai, a + J->iv, 6 * sizeof(double));
            memset(m->cj + 6 * i, 0, 6 * sizeof(double));
        } else {
            double vJ[6] = {0, 0, 0, 0, 0, 0};
            if (J->parent >= 0) {
                PC_MOTION_INV(m, m->Rl, m->pl, m->csl, i, m->vj + 6 * J->parent, vi);
                PC_MOTION_INV(m, m->Rl, m->pl, m->csl, i, m->aj + 6 * J->parent, ai);
            } else {
                memset(vi, 0, 6 * sizeof(double));
                memset(ai, 0, 6 * sizeof(double));
            }
            vJ[3 + J->kind] = v[J->iv];
            vi[3 + J->kind] += v[J->iv];
            cross_motion(vi, vJ, m->cj + 6 * i);
            for (k = 0; k < 6; k++) ai[k] += m->cj[6 * i + k];
            ai[3 + J->kind] += a[J->iv];
        }
        inertia_mul(J->pi, vi, Iv);
        inertia_mul(J->pi, ai, Ia);
        cross_force(vi, Iv, b);
        for (k = 0; k < 6; k++) m->fj[6 * i + k] = Ia[k] + b[k];
    }
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* fi = m->fj + 6 * i;
        if (J->kind < 0) memcpy(tau + J->iv, fi, 6 * sizeof(double));
        else tau[J->iv] = fi[3 + J->kind];
        if (J->parent >= 0) {
            double f[6];
            PC_FORCE_ACT(m, m->Rl, m->pl, m->csl, i, fi, f);
            for (k = 0; k < 6; k++) m->fj[6 * J->parent + k] += f[k];
        }
    }
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ factorization */
/* M(q) + diag(armature) by the articulated-body recursion at zero velocity (no velocity terms). */
int pc_factorize(pc_model_t* m, const double* q, const double* armature, pc_factor_t* F) {
    int i, k;
    pc_kinematics(m, q);
    memcpy(F->R, m->Rl, (size_t)m->nj * 9 * sizeof(double));
    memcpy(F->p, m->pl, (size_t)m->nj * 3 * sizeof(double));
    memcpy(F->cs, m->csl, (size_t)m->nj * 2 * sizeof(double));
    for (i = 0; i < m->nj; i++) pc_joint_inertia_matrix(m->joints[i].pi, m->IA + 36 * i);
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* IA = m->IA + 36 * i;
        if (J->kind < 0) continue;
        {
            int a = 3 + J->kind, r, c;
            double* U = F->U + 6 * i;
            double D;
            for (k = 0; k < 6; k++) U[k] = IA[6 * k + a];
            D = U[a] + (armature ? armature[J->iv] : 0.0);
            if (!(D > 0.0)) {
                pc_set_error(m, "joint %d: non-positive articulated inertia", i);
                return PC_ERR_SINGULAR;
            }
            F->Dinv[i] = 1.0 / D;
            if (J->parent >= 0) {
                double Ia[36];
                for (r = 0; r < 6; r++)
                    for (c = 0; c < 6; c++) Ia[6 * r + c] = IA[6 * r + c] - U[r] * U[c] / D;
                pc_add_transformed_inertia(F->R + 9 * i, F->p + 3 * i, Ia, m->IA + 36 * J->parent);
            }
        }
    }
    if (m->free_flyer) {
        memcpy(F->root, m->IA, 36 * sizeof(double));
        if (chol6(F->root)) {
            pc_set_error(m, "articulated inertia of the root is not positive definite");
            return PC_ERR_SINGULAR;
        }
    }
    F->valid = 1;
    m->n_factor++;
    return PC_OK;
}

/* x <- (M + diag(armature))^-1 x at the factorization point, O(n). */
void pc_factor_solve(const pc_model_t* m, const pc_factor_t* F, double* x) {
    int i, k;
    double* pA = m->fj;
    double* ai = m->aj;
    double* u = m->uj;
    memset(pA, 0, (size_t)m->nj * 6 * sizeof(double));
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        if (J->kind < 0) continue;
        u[i] = x[J->iv] - pA[6 * i + 3 + J->kind];
        if (J->parent >= 0) {
            double pa[6], f[6];
            const double* U = F->U + 6 * i;
            double s = u[i] * F->Dinv[i];
            for (k = 0; k < 6; k++) pa[k] = pA[6 * i + k] + U[k] * s;
            PC_FORCE_ACT(m, F->R, F->p, F->cs, i, pa, f);
            for (k = 0; k < 6; k++) pA[6 * J->parent + k] += f[k];
        }
    }
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* a = ai + 6 * i;
        if (J->kind < 0) {
            for (k = 0; k < 6; k++) a[k] = x[J->iv + k] - pA[k];
            chol6_solve(F->root, a);
            memcpy(x + J->iv, a, 6 * sizeof(double));
        } else {
            double y;
            if (J->parent >= 0) PC_MOTION_INV(m, F->R, F->p, F->cs, i, ai + 6 * J->parent, a);
            else memset(a, 0, 6 * sizeof(double));
            y = (u[i] - dot6(F->U + 6 * i, a)) * F->Dinv[i];
            x[J->iv] = y;
            a[3 + J->kind] += y;
        }
    }
}

int pc_mass_matrix(pc_model_t* m, const double* q, double* M) {
    int j, i;
    double* zero = m->tmp_nv[5];
    double* e = m->tmp_nv[6];
    double* col = m->tmp_nv[4];
    memset(zero, 0, (size_t)m->nv * sizeof(double));
    for (j = 0; j < m->nv; j++) {
        memset(e, 0, (size_t)m->nv * sizeof(double));
        e[j] = 1.0;
        pc_rnea(m, q, zero, e, col);
        for (i = 0; i < m->nv; i++) M[(size_t)i * m->nv + j] = col[i];
    }
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ Lie group */
/* q1 = q (+) dq: SE(3) exponential on the free flyer (quaternion form), addition on the angles. */
int pc_integrate(const pc_model_t* m, const double* q, const double* dq, double* q1) {
    int i, off = m->nq - m->nv;
    if (m->free_flyer) {
        const double* v = dq;
        const double* w = dq + 3;
        double t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], sh, ch, cc, bc, wxv[3], wwv[3], Vv[3], R0[9], d[3];
        double e[4], a[4], qn[4], dotq, n2, s;
        if (t2 < 1e-2) {
            sh = 0.5 + t2 * (-1.0 / 48 + t2 * (1.0 / 3840 + t2 * (-1.0 / 645120 + t2 * (1.0 / 185794560))));
            ch = 1.0 + t2 * (-1.0 / 8 + t2 * (1.0 / 384 + t2 * (-1.0 / 46080 + t2 * (1.0 / 10321920))));
            cc = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880 + t2 * (1.0 / 39916800))));
        } else {
            double t = sqrt(t2);
            sh = sin(0.5 * t) / t;
            ch = cos(0.5 * t);
            cc = (t - sin(t)) / (t2 * t);
        }
        bc = 2.0 * sh * sh;
        cross3(w, v, wxv);
        cross3(w, wxv, wwv);
        for (i = 0; i < 3; i++) Vv[i] = v[i] + bc * wxv[i] + cc * wwv[i];
        quat_to_matrix(q + 3, R0);
        mv3(R0, Vv, d);
        for (i = 0; i < 3; i++) q1[i] = q[i] + d[i];
        e[0] = sh * w[0]; e[1] = sh * w[1]; e[2] = sh * w[2]; e[3] = ch;
        for (i = 0; i < 4; i++) a[i] = q[3 + i];
        qn[0] = a[3] * e[0] + a[0] * e[3] + a[1] * e[2] - a[2] * e[1];
        qn[1] = a[3] * e[1] - a[0] * e[2] + a[1] * e[3] + a[2] * e[0];
        qn[2] = a[3] * e[2] + a[0] * e[1] - a[1] * e[0] + a[2] * e[3];
        qn[3] = a[3] * e[3] - a[0] * e[0] - a[1] * e[1] - a[2] * e[2];
        dotq = qn[0] * a[0] + qn[1] * a[1] + qn[2] * a[2] + qn[3] * a[3];
        if (dotq < 0) for (i = 0; i < 4; i++) qn[i] = -qn[i];
        n2 = qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3];
        s = (3.0 - n2) / 2.0;
        for (i = 0; i < 4; i++) q1[3 + i] = qn[i] * s;
    }
    for (i = m->n_root_v; i < m->nv; i++) q1[i + off] = q[i + off] + dq[i];
    return PC_OK;
}

static void skew3(const double* a, double* S) {
    S[0] = 0; S[1] = -a[2]; S[2] = a[1]; S[3] = a[2]; S[4] = 0; S[5] = -a[0]; S[6] = -a[1]; S[7] = a[0]; S[8] = 0;
}

/* Tangent maps of q1 = q0 exp(xi) on SE(3): J0 = d q1 / d q0 = Ad(exp(xi)^-1), Jr = d q1 / d xi (right
 * Jacobian of the exponential), both 6x6 for right perturbations (Pinocchio's dIntegrate). */
void pc_dintegrate_root(const double* xi, double* J0, double* Jr) {
    const double* v = xi;
    const double* w = xi + 3;
    double t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    double a, b, c2, c3, c4, W[9], V[9], W2[9], Re[9], pe[3], Vm[9], J3[9], Q[9];
    double WV[9], VW[9], WVW[9], WWV[9], VWW[9], WVWW[9], WWVW[9], tmp[9], RtP[9], P[9];
    int i, j;
    if (t2 < 1e-2) {
        a = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320)));  /* (1 - cos t)/t^2 */
        b = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880))); /* (t - sin t)/t^3 */
        c3 = 1.0 / 24 + t2 * (-1.0 / 720 + t2 * (1.0 / 40320 + t2 * (-1.0 / 3628800)));
        c4 = 1.0 / 120 + t2 * (-1.0 / 2520 + t2 * (1.0 / 120960));
    } else {
        double t = sqrt(t2), s = sin(t), co = cos(t);
        a = (1 - co) / t2;
        b = (t - s) / (t2 * t);
        c3 = (t2 + 2 * co - 2) / (2 * t2 * t2);
        c4 = (2 * t - 3 * s + t * co) / (2 * t2 * t2 * t);
    }
    c2 = b;
    skew3(w, W);
    skew3(v, V);
    mm3(W, W, W2);
    /* exp(xi) = (Re, pe), Re = I + sin t/t W + a W^2, pe = (I + a W + b W^2) v */
    {
        double sinc = 1.0 - t2 * b; /* sin t / t */
        for (i = 0; i < 9; i++) {
            Re[i] = sinc * W[i] + a * W2[i];
            Vm[i] = a * W[i] + b * W2[i];
            J3[i] = -a * W[i] + b * W2[i];
        }
        for (i = 0; i < 3; i++) { Re[4 * i] += 1.0; Vm[4 * i] += 1.0; J3[4 * i] += 1.0; }
    }
    mv3(Vm, v, pe);
    mm3(W, V, WV);
    mm3(V, W, VW);
    mm3(WV, W, WVW);
    mm3(W, WV, WWV);
    mm3(VW, W, VWW);
    mm3(WVW, W, WVWW);
    mm3(W, WVW, WWVW);
    for (i = 0; i < 9; i++)
        Q[i] = -0.5 * V[i] + c2 * (WV[i] + VW[i] - WVW[i]) - c3 * (WWV[i] + VWW[i] - 3 * WVW[i]) + c4 * (WVWW[i] + WWVW[i]);
    memset(Jr, 0, 36 * sizeof(double));
    memset(J0, 0, 36 * sizeof(double));
    skew3(pe, P);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) tmp[3 * i + j] = Re[3 * j + i]; /* Re^T */
    mm3(tmp, P, RtP);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            Jr[6 * i + j] = J3[3 * i + j];
            Jr[6 * (3 + i) + 3 + j] = J3[3 * i + j];
            Jr[6 * i + 3 + j] = Q[3 * i + j];
            J0[6 * i + j] = tmp[3 * i + j];
            J0[6 * (3 + i) + 3 + j] = tmp[3 * i + j];
            J0[6 * i + 3 + j] = -RtP[3 * i + j];
        }
}

/* ------------------------------------------------------------------------------------ chart kinematics */
/* G(xi) V = V + [xi, V]/2 + [xi, [xi, V]]/12 on se(3) (the truncated inverse differential of exp). */
void pc_dexpinv_apply(const double* xi, const double* V, double* out) {
    double a[6], b[6];
    int i;
    cross_motion(xi, V, a);
    cross_motion(xi, a, b);
    for (i = 0; i < 6; i++) out[i] = V[i] + 0.5 * a[i] + b[i] / 12.0;
}

static void ad6(const double* x, double* A) { /* ad_x: ad_x y = x cross y (twists), 6x6 */
    double P[9], Rm[9];
    int i, j;
    skew3(x + 3, P);
    skew3(x, Rm);
    memset(A, 0, 36 * sizeof(double));
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            A[6 * i + j] = P[3 * i + j];
            A[6 * i + 3 + j] = Rm[3 * i + j];
            A[6 * (3 + i) + 3 + j] = P[3 * i + j];
        }
}

static void mm6(const double* A, const double* B, double* C) {
    int i, j, k;
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) {
            double s = 0.0;
            for (k = 0; k < 6; k++) s += A[6 * i + k] * B[6 * k + j];
            C[6 * i + j] = s;
        }
}

/* G = dexpinv(xi) (6x6) and Gx = d(G V)/d xi = -ad_V/2 - (ad_{[xi, V]} + ad_xi ad_V)/12. */
void pc_dexpinv_mats(const double* xi, const double* V, double* G, double* Gx) {
    double A[36], A2[36], adV[36], adAV[36], AadV[36], AV[6];
    int i;
    ad6(xi, A);
    mm6(A, A, A2);
    for (i = 0; i < 36; i++) G[i] = 0.5 * A[i] + A2[i] / 12.0;
    for (i = 0; i < 6; i++) G[6 * i + i] += 1.0;
    ad6(V, adV);
    mv6(A, V, AV);
    ad6(AV, adAV);
    mm6(A, adV, AadV);
    for (i = 0; i < 36; i++) Gx[i] = -0.5 * adV[i] - (adAV[i] + AadV[i]) / 12.0;
}

/* ------------------------------------------------------------------------------------ dense LU */
int pc_lu_factor(double* A, int* piv, int n) {
    int i, j, k;
    for (k = 0; k < n; k++) {
        int p = k;
        double big = fabs(A[k * n + k]);
        for (i = k + 1; i < n; i++)
            if (fabs(A[i * n + k]) > big) { big = fabs(A[i * n + k]); p = i; }
        piv[k] = p;
        if (big == 0.0 || !(big < INFINITY)) return 1;
        if (p != k)
            for (j = 0; j < n; j++) { double t = A[k * n + j]; A[k * n + j] = A[p * n + j]; A[p * n + j] = t; }
        for (i = k + 1; i < n; i++) {
            double f = A[i * n + k] / A[k * n + k];
            A[i * n + k] = f;
            if (f != 0.0)
                for (j = k + 1; j < n; j++) A[i * n + j] -= f * A[k * n + j];
        }
    }
    return 0;
}

/* Solve in place for B (n x m, row-major, leading dimension ld). */
void pc_lu_solve(const double* LU, const int* piv, int n, double* B, int m, int ld) {
    int i, j, k;
    for (k = 0; k < n; k++)
        if (piv[k] != k)
            for (j = 0; j < m; j++) { double t = B[k * ld + j]; B[k * ld + j] = B[piv[k] * ld + j]; B[piv[k] * ld + j] = t; }
    for (i = 1; i < n; i++)
        for (k = 0; k < i; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) for (j = 0; j < m; j++) B[i * ld + j] -= f * B[k * ld + j];
        }
    for (i = n - 1; i >= 0; i--) {
        double inv = 1.0 / LU[i * n + i];
        for (k = i + 1; k < n; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) for (j = 0; j < m; j++) B[i * ld + j] -= f * B[k * ld + j];
        }
        for (j = 0; j < m; j++) B[i * ld + j] *= inv;
    }
}

/* ------------------------------------------------------------------------------------ outputs */
/* z = [accelerometer (3, B components), arm joint accelerations (n_arm; zero when locked)]:
 * a = dv/dt + w x v + dw/dt x r + w x (w x r) with the root's body twist (v, w). */
void pc_measurement(pc_model_t* m, const double* q, const double* v, const double* ddq, double* z) {
    double wv[3], dwr[3], wr[3], wwr[3];
    int i;
    (void)q;
    if (!m->free_flyer) { /* a chain on a fixed base: no chaser to carry an accelerometer */
        for (i = 0; i < m->nz; i++) z[i] = 0.0;
        return;
    }
    cross3(v + 3, v, wv);
    cross3(ddq + 3, m->r_acc, dwr);
    cross3(v + 3, m->r_acc, wr);
    cross3(v + 3, wr, wwr);
    for (i = 0; i < 3; i++) z[i] = ddq[i] + wv[i] + dwr[i] + wwr[i];
    for (i = 0; i < m->n_arm; i++) z[3 + i] = i < m->n_arm_v ? ddq[m->arm_v[i]] : 0.0;
}

/* World placement of a panel's root frame (its joint may be the universe, -1, for a chain on a fixed base). */
static void root_frame(const pc_model_t* m, const pc_panel_t* P, double* Rr, double* pr) {
    int k;
    if (P->root_joint < 0) {
        memcpy(Rr, P->R, 9 * sizeof(double));
        memcpy(pr, P->p, 3 * sizeof(double));
        return;
    }
    {
        double t3[3];
        mm3(m->Ro + 9 * P->root_joint, P->R, Rr);
        mv3(m->Ro + 9 * P->root_joint, P->p, t3);
        for (k = 0; k < 3; k++) pr[k] = m->po[3 * P->root_joint + k] + t3[k];
    }
}

/* Per panel: the tip deflection in the panel's root frame (3, the undeformed tip at (length, 0, 0)
 * subtracted) and the root torsion angle; needs the world placements of q (pc_world_placements). */
void pc_panel_outputs(const pc_model_t* m, const double* q, double* out) {
    int i, k, off = m->nq - m->nv;
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        double Rr[9], pr[3], pt[3], d[3], t3[3];
        root_frame(m, P, Rr, pr);
        mv3(m->Ro + 9 * P->tip_joint, P->tip, t3);
        for (k = 0; k < 3; k++) { pt[k] = m->po[3 * P->tip_joint + k] + t3[k]; d[k] = pt[k] - pr[k]; }
        mtv3(Rr, d, out + 4 * i);
        out[4 * i] -= P->length;
        out[4 * i + 3] = P->torsion_v >= 0 ? q[P->torsion_v + off] : 0.0;
    }
}

/* d(panel outputs)/dq (4 npanels x nv, tangent; the tip in the root frame depends on the panel's own
 * joints only: a revolute joint j on the chain moves the tip by a_j x (p_tip - o_j)); needs the world
 * placements of q. */
void pc_panel_jacobian(const pc_model_t* m, double* J) {
    int i, k, nv = m->nv;
    memset(J, 0, (size_t)4 * m->npanels * nv * sizeof(double));
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        double Rr[9], pr[3], pt[3], t3[3];
        int j = P->tip_joint;
        root_frame(m, P, Rr, pr);
        mv3(m->Ro + 9 * P->tip_joint, P->tip, t3);
        for (k = 0; k < 3; k++) pt[k] = m->po[3 * P->tip_joint + k] + t3[k];
        while (j >= 0 && j != P->root_joint) {
            const pc_joint_t* Jn = &m->joints[j];
            if (Jn->kind >= 0) {
                double a[3], r[3], c[3], loc[3];
                for (k = 0; k < 3; k++) { a[k] = m->Ro[9 * j + 3 * k + Jn->kind]; r[k] = pt[k] - m->po[3 * j + k]; }
                cross3(a, r, c);
                mtv3(Rr, c, loc);
                for (k = 0; k < 3; k++) J[(size_t)(4 * i + k) * nv + Jn->iv] = loc[k];
            }
            j = Jn->parent;
        }
        if (P->torsion_v >= 0) J[(size_t)(4 * i + 3) * nv + P->torsion_v] = 1.0;
    }
}

/* d(panel outputs)/d(root quaternion components x, y, z, w) in the ambient configuration (4 npanels x
 * 4). The tips are relative to the root body, so they move only when the quaternion's norm changes the
 * matrix it is read as (Eigen's formula): tip = A^T R0^T R0 b, with A and b the root frame and the tip
 * in root-body axes; exact at a unit quaternion. Needs the world placements of q. */
void pc_panel_quat_jacobian(const pc_model_t* m, const double* q, double* J) {
    const double* a = q + 3;
    double R0[9], dR[4][9];
    int i, c, k, r;
    double x = a[0], y = a[1], z = a[2], w = a[3];
    quat_to_matrix(a, R0);
    /* d R0 / d(x, y, z, w) */
    {
        double D[4][9] = {
            {0, 2 * y, 2 * z, 2 * y, -4 * x, -2 * w, 2 * z, 2 * w, -4 * x},
            {-4 * y, 2 * x, 2 * w, 2 * x, 0, 2 * z, -2 * w, 2 * z, -4 * y},
            {-4 * z, -2 * w, 2 * x, 2 * w, -4 * z, 2 * y, 2 * x, 2 * y, 0},
            {0, -2 * z, 2 * y, 2 * z, 0, -2 * x, -2 * y, 2 * x, 0},
        };
        memcpy(dR, D, sizeof dR);
    }
    memset(J, 0, (size_t)16 * m->npanels * sizeof(double));
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        double Rr[9], pr[3], pt[3], d[3], t3[3], A[9], b[3];
        root_frame(m, P, Rr, pr);
        mv3(m->Ro + 9 * P->tip_joint, P->tip, t3);
        for (k = 0; k < 3; k++) { pt[k] = m->po[3 * P->tip_joint + k] + t3[k]; d[k] = pt[k] - pr[k]; }
        for (r = 0; r < 3; r++)
            for (k = 0; k < 3; k++) A[3 * r + k] = R0[r] * Rr[k] + R0[3 + r] * Rr[3 + k] + R0[6 + r] * Rr[6 + k];
        mtv3(R0, d, b);
        for (c = 0; c < 4; c++) {
            double S[9], Sb[3], col[3];
            for (r = 0; r < 3; r++)
                for (k = 0; k < 3; k++) {
                    double s1 = 0.0;
                    int l;
                    for (l = 0; l < 3; l++) s1 += dR[c][3 * l + r] * R0[3 * l + k] + R0[3 * l + r] * dR[c][3 * l + k];
                    S[3 * r + k] = s1;
                }
            mv3(S, b, Sb);
            mtv3(A, Sb, col);
            for (k = 0; k < 3; k++) J[(size_t)(4 * i + k) * 4 + c] = col[k];
        }
    }
}

/* Everything recorded at a sample: ddq (nv), the panels' outputs (4 each, pc_panel_outputs), and
 * mech = [centre of mass (3), linear momentum (3), angular momentum about the centre of mass (3),
 * kinetic energy, elastic energy] in the world frame N, then the measurement z (nz). */
int pc_sample(pc_model_t* m, const double* q, const double* v, double t, double* ddq, double* panels, double* mech) {
    double* u = m->tmp_nv[6];
    double mass = 0.0, mc[3] = {0, 0, 0}, P[3] = {0, 0, 0}, H[3] = {0, 0, 0}, ke = 0.0, pe = 0.0;
    int i, k, err;
    double* uu = (double*)malloc(((size_t)m->nu + 1) * sizeof(double));
    if (!uu) return PC_ERR_MEMORY;
    pc_inputs(m, t, 0, uu);
    (void)u;
    err = pc_accel(m, q, v, uu, ddq);
    free(uu);
    if (err) return err;
    pc_world_placements(m); /* pc_accel left the joint placements of q */
    for (i = 0; i < m->nj; i++) {
        const double* pi = m->joints[i].pi;
        const double* Ro = m->Ro + 9 * i;
        const double* po = m->po + 3 * i;
        double h[6], hw[6], c[3];
        inertia_mul(pi, m->vj + 6 * i, h);
        ke += 0.5 * dot6(m->vj + 6 * i, h);
        force_act(Ro, po, h, hw);
        for (k = 0; k < 3; k++) { P[k] += hw[k]; H[k] += hw[3 + k]; }
        mv3(Ro, pi + 1, c); /* first moment, world axes, about the joint origin */
        mass += pi[0];
        for (k = 0; k < 3; k++) mc[k] += c[k] + pi[0] * po[k];
    }
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        int off = m->nq - m->nv;
        double d = S->a[0] * q[S->v[0] + off] - S->rest;
        if (S->v[1] >= 0) d += S->a[1] * q[S->v[1] + off];
        pe += 0.5 * S->k * d * d;
    }
    for (k = 0; k < 3; k++) mc[k] /= mass;
    if (mech) {
        double cp[3];
        cross3(mc, P, cp);
        for (k = 0; k < 3; k++) { mech[k] = mc[k]; mech[3 + k] = P[k]; mech[6 + k] = H[k] - cp[k]; }
        mech[9] = ke;
        mech[10] = pe;
        pc_measurement(m, q, v, ddq, mech + 11);
    }
    if (panels) pc_panel_outputs(m, q, panels);
    return PC_OK;
}
