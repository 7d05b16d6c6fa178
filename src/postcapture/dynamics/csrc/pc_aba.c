/*
 * postcapture plant core: Featherstone's articulated-body algorithm. Owns the forward dynamics
 * ddq = M^-1 (tau - b(q, v)) in O(n), the forward dynamics with the model's forces (springs, dampers,
 * inputs), and the articulated factorization of M(q) + diag(armature) with its O(n) solve, which the
 * implicit integrators' Newton iterations and the derivatives' M^-1 columns use.
 */
#include "pc_internal.h"

/* first pass: body twists, bias accelerations, inertias and bias forces */
static void aba_velocities(const pc_model_t* m, pc_data_t* d, const double* v) {
    int i;
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* vi = d->vj + 6 * i;
        double* ci = d->cj + 6 * i;
        double Iv[6];
        if (J->kind < 0) {
            memcpy(vi, v + J->iv, 6 * sizeof(double));
            memset(ci, 0, 6 * sizeof(double));
        } else {
            double vJ[6] = {0, 0, 0, 0, 0, 0};
            if (J->parent >= 0) PC_MOTION_INV(m, d->Rl, d->pl, d->csl, i, d->vj + 6 * J->parent, vi);
            else memset(vi, 0, 6 * sizeof(double));
            vJ[3 + J->kind] = v[J->iv];
            vi[3 + J->kind] += v[J->iv];
            cross_motion(vi, vJ, ci);
        }
        pc_joint_inertia_matrix(d->pi + 10 * i, d->IA + 36 * i);
        inertia_mul(d->pi + 10 * i, vi, Iv);
        cross_force(vi, Iv, d->fj + 6 * i); /* bias force pA */
    }
}

/* second pass: articulated inertias and bias forces, leaves to root */
static void aba_articulated(const pc_model_t* m, pc_data_t* d, const double* tau) {
    int i, k, r, c;
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* IA = d->IA + 36 * i;
        double* pA = d->fj + 6 * i;
        double* U = d->Uj + 6 * i;
        double D, u, Ia[36], pa[6], Ic[6], f[6];
        int a = 3 + J->kind;
        if (J->kind < 0) continue;
        for (k = 0; k < 6; k++) U[k] = IA[6 * k + a];
        D = U[a];
        u = tau[J->iv] - pA[a];
        d->Dj[i] = D;
        d->uj[i] = u;
        if (J->parent < 0) continue;
        for (r = 0; r < 6; r++)
            for (c = 0; c < 6; c++) Ia[6 * r + c] = IA[6 * r + c] - U[r] * U[c] / D;
        mv6(Ia, d->cj + 6 * i, Ic);
        for (k = 0; k < 6; k++) pa[k] = pA[k] + Ic[k] + U[k] * (u / D);
        pc_add_transformed_inertia(d->Rl + 9 * i, d->pl + 3 * i, Ia, d->IA + 36 * J->parent);
        PC_FORCE_ACT(m, d->Rl, d->pl, d->csl, i, pa, f);
        for (k = 0; k < 6; k++) d->fj[6 * J->parent + k] += f[k];
    }
}

int pc_aba(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* tau, double* ddq) {
    int i, k;
    pc_kinematics(m, d, q);
    aba_velocities(m, d, v);
    aba_articulated(m, d, tau);
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* ai = d->aj + 6 * i;
        if (J->kind < 0) {
            double L[36];
            memcpy(L, d->IA, sizeof L);
            for (k = 0; k < 6; k++) ai[k] = tau[J->iv + k] - d->fj[k];
            if (pc_chol6(L)) {
                pc_set_error(d, "articulated inertia of the root is not positive definite");
                return PC_ERR_SINGULAR;
            }
            pc_chol6_solve(L, ai);
            memcpy(ddq + J->iv, ai, 6 * sizeof(double));
        } else {
            double x;
            if (J->parent >= 0) PC_MOTION_INV(m, d->Rl, d->pl, d->csl, i, d->aj + 6 * J->parent, ai);
            else memset(ai, 0, 6 * sizeof(double));
            for (k = 0; k < 6; k++) ai[k] += d->cj[6 * i + k];
            x = (d->uj[i] - dot6(d->Uj + 6 * i, ai)) / d->Dj[i];
            ddq[J->iv] = x;
            ai[3 + J->kind] += x;
        }
    }
    return PC_OK;
}

int pc_accel(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u, double* ddq) {
    double* tau = d->tmp_nv[7];
    pc_force(m, d, q, v, u, tau);
    return pc_aba(m, d, q, v, tau, ddq);
}

/* M(q) + diag(armature) by the articulated-body recursion at zero velocity (no velocity terms). */
int pc_factorize(const pc_model_t* m, pc_data_t* d, const double* q, const double* armature, pc_factor_t* F) {
    int i, k, r, c;
    pc_kinematics(m, d, q);
    memcpy(F->R, d->Rl, (size_t)m->nj * 9 * sizeof(double));
    memcpy(F->p, d->pl, (size_t)m->nj * 3 * sizeof(double));
    memcpy(F->cs, d->csl, (size_t)m->nj * 2 * sizeof(double));
    for (i = 0; i < m->nj; i++) pc_joint_inertia_matrix(d->pi + 10 * i, d->IA + 36 * i);
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* IA = d->IA + 36 * i;
        double* U = F->U + 6 * i;
        double D, Ia[36];
        int a = 3 + J->kind;
        if (J->kind < 0) continue;
        for (k = 0; k < 6; k++) U[k] = IA[6 * k + a];
        D = U[a] + (armature ? armature[J->iv] : 0.0);
        if (!(D > 0.0)) {
            pc_set_error(d, "joint %d: non-positive articulated inertia", i);
            return PC_ERR_SINGULAR;
        }
        F->Dinv[i] = 1.0 / D;
        if (J->parent < 0) continue;
        for (r = 0; r < 6; r++)
            for (c = 0; c < 6; c++) Ia[6 * r + c] = IA[6 * r + c] - U[r] * U[c] / D;
        pc_add_transformed_inertia(F->R + 9 * i, F->p + 3 * i, Ia, d->IA + 36 * J->parent);
    }
    if (m->free_flyer) {
        memcpy(F->root, d->IA, 36 * sizeof(double));
        if (pc_chol6(F->root)) {
            pc_set_error(d, "articulated inertia of the root is not positive definite");
            return PC_ERR_SINGULAR;
        }
    }
    F->valid = 1;
    return PC_OK;
}

/* x <- (M + diag(armature))^-1 x at the factorization point, O(n). */
void pc_factor_solve(const pc_model_t* m, pc_data_t* d, const pc_factor_t* F, double* x) {
    int i, k;
    double* pA = d->fj;
    double* ai = d->aj;
    double* u = d->uj;
    memset(pA, 0, (size_t)m->nj * 6 * sizeof(double));
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double pa[6], f[6], s;
        const double* U = F->U + 6 * i;
        if (J->kind < 0) continue;
        u[i] = x[J->iv] - pA[6 * i + 3 + J->kind];
        if (J->parent < 0) continue;
        s = u[i] * F->Dinv[i];
        for (k = 0; k < 6; k++) pa[k] = pA[6 * i + k] + U[k] * s;
        PC_FORCE_ACT(m, F->R, F->p, F->cs, i, pa, f);
        for (k = 0; k < 6; k++) pA[6 * J->parent + k] += f[k];
    }
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* a = ai + 6 * i;
        if (J->kind < 0) {
            for (k = 0; k < 6; k++) a[k] = x[J->iv + k] - pA[k];
            pc_chol6_solve(F->root, a);
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
