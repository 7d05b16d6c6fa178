/*
 * postcapture plant core: the recursive Newton-Euler algorithm. Owns the inverse dynamics
 * tau = M(q) a + b(q, v) in O(n) (leaving each body's twist, acceleration and subtree wrench in the
 * data) and its partials in the parameter vector: the target's ten inertial parameters enter linearly
 * through the joint that carries it, the spring and damper scales through the springs.
 */
#include "pc_internal.h"

/* forward pass: twists, accelerations, bias accelerations and body wrenches */
static void rnea_forward(const pc_model_t* m, pc_data_t* d, const double* v, const double* a) {
    int i, k;
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* vi = d->vj + 6 * i;
        double* ai = d->aj + 6 * i;
        double Iv[6], Ia[6], b[6];
        if (J->kind < 0) {
            memcpy(vi, v + J->iv, 6 * sizeof(double));
            memcpy(ai, a + J->iv, 6 * sizeof(double));
            memset(d->cj + 6 * i, 0, 6 * sizeof(double));
        } else {
            double vJ[6] = {0, 0, 0, 0, 0, 0};
            if (J->parent >= 0) {
                PC_MOTION_INV(m, d->Rl, d->pl, d->csl, i, d->vj + 6 * J->parent, vi);
                PC_MOTION_INV(m, d->Rl, d->pl, d->csl, i, d->aj + 6 * J->parent, ai);
            } else {
                memset(vi, 0, 6 * sizeof(double));
                memset(ai, 0, 6 * sizeof(double));
            }
            vJ[3 + J->kind] = v[J->iv];
            vi[3 + J->kind] += v[J->iv];
            cross_motion(vi, vJ, d->cj + 6 * i);
            for (k = 0; k < 6; k++) ai[k] += d->cj[6 * i + k];
            ai[3 + J->kind] += a[J->iv];
        }
        inertia_mul(d->pi + 10 * i, vi, Iv);
        inertia_mul(d->pi + 10 * i, ai, Ia);
        cross_force(vi, Iv, b);
        for (k = 0; k < 6; k++) d->fj[6 * i + k] = Ia[k] + b[k];
    }
}

int pc_rnea(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* a, double* tau) {
    int i, k;
    pc_kinematics(m, d, q);
    rnea_forward(m, d, v, a);
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        double* fi = d->fj + 6 * i;
        if (J->kind < 0) memcpy(tau + J->iv, fi, 6 * sizeof(double));
        else tau[J->iv] = fi[3 + J->kind];
        if (J->parent >= 0) {
            double f[6];
            PC_FORCE_ACT(m, d->Rl, d->pl, d->csl, i, fi, f);
            for (k = 0; k < 6; k++) d->fj[6 * J->parent + k] += f[k];
        }
    }
    return PC_OK;
}

/* add the wrench f (in joint cur's frame, parameter column k) to the generalized forces of cur and its
 * ancestors */
static void wrench_up(const pc_model_t* m, const pc_data_t* d, int cur, double* f, int k, double* Tp) {
    int r, np = m->np;
    double up[6];
    while (cur >= 0) {
        const pc_joint_t* J = &m->joints[cur];
        if (J->kind < 0)
            for (r = 0; r < 6; r++) Tp[(size_t)(J->iv + r) * np + k] += f[r];
        else
            Tp[(size_t)J->iv * np + k] += f[3 + J->kind];
        if (J->parent >= 0) {
            force_act(d->Rl + 9 * cur, d->pl + 3 * cur, f, up);
            memcpy(f, up, 6 * sizeof(double));
        }
        cur = J->parent;
    }
}

/* Tp = d(tau - ID)/dp at (q, v, a) for every parameter, nv x np row-major. Needs the RNEA twists and
 * accelerations of (q, v, a) in the data (call after pc_rnea). */
void pc_param_forces(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double* Tp) {
    int k, r;
    memset(Tp, 0, (size_t)m->nv * m->np * sizeof(double));
    if (m->target_joint >= 0) {
        int tj = m->target_joint;
        const double* vt = d->vj + 6 * tj;
        const double* at = d->aj + 6 * tj;
        for (k = 0; k < 10; k++) {
            double pi[10], f[6], Iv[6], b[6];
            for (r = 0; r < 10; r++) pi[r] = m->t_L[10 * r + k];
            inertia_mul(pi, at, f);
            inertia_mul(pi, vt, Iv);
            cross_force(vt, Iv, b);
            for (r = 0; r < 6; r++) f[r] = -(f[r] + b[r]);
            wrench_up(m, d, tj, f, k, Tp);
        }
    }
    pc_spring_param_forces(m, q, v, Tp);
}
