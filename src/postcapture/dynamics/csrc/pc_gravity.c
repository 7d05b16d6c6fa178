/*
 * postcapture plant core: the gravity gradient of a circular orbit. Owns an instance's orbit (its mean
 * motion n and the time at which forces are evaluated) and the generalized force the tidal field exerts on
 * every body, with the field's total force and moment about N's origin for the energy and momentum balance.
 *
 * N is the local-vertical local-horizontal frame of the reference orbit at t = 0 (x the zenith, y along the
 * track, z the orbit normal), not rotating; its origin is the reference point, which falls freely along the
 * circular orbit, so the uniform part of gravity cancels and what acts is the tidal field
 *     g(x) = n^2 (3 (r . x) r - x),   r = (cos n t, sin n t, 0) the zenith at t.
 * On a body with mass m, first moment h = int x dm and second moment J = int x x^T dm about N's origin:
 *     F = n^2 (3 r (r . h) - h),   M = 3 n^2 (J r) x r   (about N's origin: the classic 3 n^2 r x I r).
 * The generalized force of revolute joint j (world axis a, through p) is a . (M_sub - p x F_sub) over the
 * bodies it carries; the free flyer's is [R^T F_sub; R^T (M_sub - p x F_sub)].
 */
#include "pc_internal.h"

int pc_set_orbit(const pc_model_t* m, pc_data_t* d, double mean_motion) {
    (void)m;
    if (!(mean_motion >= 0.0) || !(mean_motion < 1.0)) {
        pc_set_error(d, "orbit: expected a mean motion in [0, 1) rad/s, found %g", mean_motion);
        return PC_ERR_ARG;
    }
    d->orbit_n = mean_motion;
    return PC_OK;
}

void pc_orbit_time(pc_data_t* d, double t) { d->orbit_t = t; }

/* h (3) and J (9) of body i about N's origin, from its ten parameters about its joint origin */
static void body_moments(const pc_data_t* d, int i, double* h, double* J) {
    const double* pi = d->pi + 10 * i;
    const double* R = d->Ro + 9 * i;
    const double* p = d->po + 3 * i;
    double Io[9], Jl[9], RJ[9], hl[3], tr;
    int a, b, k;
    Io[0] = pi[4]; Io[1] = Io[3] = pi[5]; Io[4] = pi[6]; Io[2] = Io[6] = pi[7]; Io[5] = Io[7] = pi[8]; Io[8] = pi[9];
    tr = 0.5 * (Io[0] + Io[4] + Io[8]);
    for (k = 0; k < 9; k++) Jl[k] = -Io[k];
    Jl[0] += tr; Jl[4] += tr; Jl[8] += tr; /* int y y^T dm about the joint origin */
    mv3(R, pi + 1, hl);
    for (k = 0; k < 3; k++) h[k] = pi[0] * p[k] + hl[k];
    for (a = 0; a < 3; a++) /* R Jl R^T */
        for (b = 0; b < 3; b++) {
            double s = 0.0;
            for (k = 0; k < 3; k++) s += R[3 * a + k] * (Jl[3 * k + 0] * R[3 * b + 0] + Jl[3 * k + 1] * R[3 * b + 1] +
                                                         Jl[3 * k + 2] * R[3 * b + 2]);
            RJ[3 * a + b] = s;
        }
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++)
            J[3 * a + b] = RJ[3 * a + b] + pi[0] * p[a] * p[b] + p[a] * hl[b] + hl[a] * p[b];
}

/* force and moment about N's origin of the field on moments (h, J) */
static void field_wrench(double n2, const double* r, const double* h, const double* J, double* F, double* M) {
    double rh = r[0] * h[0] + r[1] * h[1] + r[2] * h[2], Jr[3];
    int k;
    for (k = 0; k < 3; k++) F[k] = n2 * (3.0 * r[k] * rh - h[k]);
    mv3(J, r, Jr);
    cross3(Jr, r, M);
    for (k = 0; k < 3; k++) M[k] *= 3.0 * n2;
}

int pc_gravity_force(const pc_model_t* m, pc_data_t* d, const double* q, double* tau, double* FM) {
    double n = d->orbit_n, n2 = n * n, r[3];
    size_t mark;
    double *h, *J;
    int i, k;
    if (FM) memset(FM, 0, 6 * sizeof(double));
    if (n == 0.0) return PC_OK;
    r[0] = cos(n * d->orbit_t); r[1] = sin(n * d->orbit_t); r[2] = 0.0;
    mark = PC_ARENA_MARK(d);
    h = pc_arena_alloc(d, (size_t)m->nj * 12);
    if (!h) return PC_ERR_MEMORY;
    J = h + 3 * (size_t)m->nj;
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    for (i = 0; i < m->nj; i++) body_moments(d, i, h + 3 * i, J + 9 * i);
    for (i = m->nj - 1; i >= 0; i--) { /* subtree sums, children first */
        int par = m->joints[i].parent;
        if (par < 0) continue;
        for (k = 0; k < 3; k++) h[3 * par + k] += h[3 * i + k];
        for (k = 0; k < 9; k++) J[9 * par + k] += J[9 * i + k];
    }
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* Jt = &m->joints[i];
        const double* R = d->Ro + 9 * i;
        const double* p = d->po + 3 * i;
        double F[3], M[3], pF[3], Mp[3];
        field_wrench(n2, r, h + 3 * i, J + 9 * i, F, M);
        cross3(p, F, pF);
        for (k = 0; k < 3; k++) Mp[k] = M[k] - pF[k]; /* moment about the joint's origin */
        if (Jt->kind < 0) {
            double Fb[3], Mb[3];
            mtv3(R, F, Fb);
            mtv3(R, Mp, Mb);
            for (k = 0; k < 3; k++) { tau[Jt->iv + k] += Fb[k]; tau[Jt->iv + 3 + k] += Mb[k]; }
        } else {
            tau[Jt->iv] += R[Jt->kind] * Mp[0] + R[3 + Jt->kind] * Mp[1] + R[6 + Jt->kind] * Mp[2];
        }
        if (FM && Jt->parent < 0) {
            for (k = 0; k < 3; k++) { FM[k] += F[k]; FM[3 + k] += M[k]; }
        }
    }
    PC_ARENA_RELEASE(d, mark);
    return PC_OK;
}
