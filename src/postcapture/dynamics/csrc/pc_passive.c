/*
 * postcapture plant core: the passive forces. Owns the linear springs and dampers on the joint
 * coordinates (tau = -a (k (a . q - rest) + d a . v) per spring): their generalized forces, their
 * partials in q and v, their partials in the stiffness and damping scales of the parameter vector, the
 * elastic energy and the dissipated power, and their contribution h g d + (h g)^2 k to the implicit
 * integrators' Newton matrix; plus the total generalized force tau = springs + B u (+ the orbit's gravity
 * gradient, pc_gravity.c).
 */
#include "pc_internal.h"

/* deflection a . q - rest and rate a . v of spring S */
static void stretch(const pc_model_t* m, const pc_spring_t* S, const double* q, const double* v, double* defl,
                    double* rate) {
    int off = m->nq - m->nv;
    if (q) {
        *defl = S->a[0] * q[S->v[0] + off] - S->rest;
        if (S->v[1] >= 0) *defl += S->a[1] * q[S->v[1] + off];
    }
    if (v) {
        *rate = S->a[0] * v[S->v[0]];
        if (S->v[1] >= 0) *rate += S->a[1] * v[S->v[1]];
    }
}

/* tau = spring and damper forces (overwrites tau); the integrators' innermost force, written out */
void pc_spring_force(const pc_model_t* m, const pc_data_t* d, const double* q, const double* v, double* tau) {
    int i, off = m->nq - m->nv;
    memset(tau, 0, (size_t)m->nv * sizeof(double));
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        double defl = S->a[0] * q[S->v[0] + off] - S->rest, rate = S->a[0] * v[S->v[0]], f;
        if (S->v[1] >= 0) {
            defl += S->a[1] * q[S->v[1] + off];
            rate += S->a[1] * v[S->v[1]];
        }
        f = -d->k[i] * defl - d->dmp[i] * rate;
        tau[S->v[0]] += S->a[0] * f;
        if (S->v[1] >= 0) tau[S->v[1]] += S->a[1] * f;
    }
}

void pc_force(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u, double* tau) {
    pc_spring_force(m, d, q, v, tau);
    pc_input_force(m, u, tau);
    if (d->orbit_n != 0.0) pc_gravity_force(m, d, q, tau, NULL);
}

/* Cq += K, Cv += D (the springs' stiffness and damping matrices, nv x nv); either may be NULL. */
void pc_spring_partials(const pc_model_t* m, const pc_data_t* d, double* Cq, double* Cv) {
    int i, x, y, nv = m->nv;
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        for (x = 0; x < 2; x++)
            for (y = 0; y < 2; y++) {
                if (S->v[x] < 0 || S->v[y] < 0) continue;
                if (Cq) Cq[(size_t)S->v[x] * nv + S->v[y]] += d->k[i] * S->a[x] * S->a[y];
                if (Cv) Cv[(size_t)S->v[x] * nv + S->v[y]] += d->dmp[i] * S->a[x] * S->a[y];
            }
    }
}

/* Tp += d tau_springs / d p (nv x np): each spring's force is linear in its two scales. */
void pc_spring_param_forces(const pc_model_t* m, const double* q, const double* v, double* Tp) {
    int i, r, np = m->np;
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        double defl = 0.0, rate = 0.0;
        stretch(m, S, q, v, &defl, &rate);
        for (r = 0; r < 2; r++) {
            if (S->v[r] < 0) continue;
            if (S->pk >= 0) Tp[(size_t)S->v[r] * np + S->pk] += -S->k0 * defl * S->a[r];
            if (S->pd >= 0) Tp[(size_t)S->v[r] * np + S->pd] += -S->d0 * rate * S->a[r];
        }
    }
}

double pc_elastic_energy(const pc_model_t* m, const pc_data_t* d, const double* q) {
    double e = 0.0, defl = 0.0;
    int i;
    for (i = 0; i < m->ns; i++) {
        stretch(m, &m->springs[i], q, NULL, &defl, NULL);
        e += 0.5 * d->k[i] * defl * defl;
    }
    return e;
}

double pc_spring_power(const pc_model_t* m, const pc_data_t* d, const double* v) {
    double p = 0.0, rate = 0.0;
    int i;
    for (i = 0; i < m->ns; i++) {
        stretch(m, &m->springs[i], NULL, v, NULL, &rate);
        p += d->dmp[i] * rate * rate;
    }
    return p;
}

/* arm[v] = sum over springs on one coordinate of a^2 (hg d + hg^2 k) (diagonal springs only) */
void pc_spring_armature(const pc_model_t* m, const pc_data_t* d, double hg, double* arm) {
    int i;
    memset(arm, 0, (size_t)m->nv * sizeof(double));
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        arm[S->v[0]] += S->a[0] * S->a[0] * (hg * d->dmp[i] + hg * hg * d->k[i]);
    }
}

/* M += hg D + hg^2 K (dense, nv x nv) */
void pc_spring_dense(const pc_model_t* m, const pc_data_t* d, double hg, double* M) {
    int i, x, y, nv = m->nv;
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        for (x = 0; x < 2; x++)
            for (y = 0; y < 2; y++)
                if (S->v[x] >= 0 && S->v[y] >= 0)
                    M[(size_t)S->v[x] * nv + S->v[y]] += S->a[x] * S->a[y] * (hg * d->dmp[i] + hg * hg * d->k[i]);
    }
}
