/*
 * postcapture plant core: the integrators. Owns the Lie-group diagonally implicit Runge-Kutta step
 * (explicit stages evaluated, implicit ones solved by Newton's method in force form), the energy and
 * momentum balance integrated with the step's own quadrature, and the truth loop (pc_simulate).
 *
 * Runge-Kutta-Munthe-Kaas in the chart q = q_k (+) xi centred on the step's start. Stage i solves
 *
 *     xi_i = h sum_j a_ij G(xi_j) V_j,   V_i = v_k + h sum_j a_ij f(q_k (+) xi_j, V_j, t_k + c_j h),
 *
 * with G the inverse differential of the exponential (on the free flyer, truncated after ad^2; the
 * identity on joint angles). Implicit stages (a_ii = g != 0) are solved by Newton's method in force
 * form: with a = (V - Vbar) / (h g), the residual is r = ID(q, V, a) - tau(q, V) (inverse dynamics minus
 * springs, dampers and inputs) and the correction dV = -h g (M + h g D + (h g)^2 K)^-1 r uses the mass
 * matrix at the step's start factorized by the articulated-body recursion with the "armature"
 * h g d_i + (h g)^2 k_i on each joint: O(n) per iteration, implicit in the stiffness and the damping.
 * (With springs coupling two coordinates, Spong rotors, the same matrix is formed densely.)
 * A stage is accepted once the RMS of its weighted correction, each coordinate scaled by
 * atol + rtol |y_i| at the predictor, is below 1 after at least two iterations, or below 0.1 at the
 * first (the predictor was already within a tenth of the tolerance). Each stage's Newton starts from
 * the same stage of the previous step, shifted by the change of the step's start.
 *
 * The warm start (the previous steps' stages) and the Newton statistics live in the instance's data;
 * every temporary comes from its arena. Step Jacobians: pc_jacobian.c.
 */
#include "pc_internal.h"

static void kxi(const pc_model_t* m, const double* xi, const double* V, double* out) {
    memcpy(out, V, (size_t)m->nv * sizeof(double));
    if (m->free_flyer) pc_dexpinv_apply(xi, V, out);
}

/* Newton matrix M(q) + hg D + (hg)^2 K at q: articulated factorization (diagonal springs) or dense LU. */
static int newton_matrix(const pc_model_t* m, pc_data_t* d, const double* q, double hg) {
    int err;
    d->n_factor++;
    if (m->diag_springs) {
        double* arm = d->tmp_nv[0];
        pc_spring_armature(m, d, hg, arm);
        return pc_factorize(m, d, q, arm, &d->fac);
    }
    if ((err = pc_crba(m, d, q, d->dense))) return err;
    pc_spring_dense(m, d, hg, d->dense);
    if (pc_lu_factor(d->dense, d->piv, m->nv)) {
        pc_set_error(d, "singular Newton matrix");
        return PC_ERR_SINGULAR;
    }
    d->fac.valid = 1;
    return PC_OK;
}

static void newton_solve(const pc_model_t* m, pc_data_t* d, double* x) {
    if (m->diag_springs) pc_factor_solve(m, d, &d->fac, x);
    else pc_lu_solve(d->dense, d->piv, m->nv, x, 1, 1);
}

/* One stage's problem: the step's start q, the inputs u, the explicit parts xi_bar, V_bar, h g. */
typedef struct {
    const double *q, *u, *xi_bar, *V_bar;
    double hg, t;
    double* qi;
} stage_t;

/* One Newton iteration on (xi, V); returns the weighted RMS^2 of the correction. */
static double newton_iteration(const pc_model_t* m, pc_data_t* d, const stage_t* S, double* xi, double* V) {
    int nv = m->nv, i, rf = m->n_root_v;
    double* r = d->tmp_nv[4];
    double* a = d->tmp_nv[5];
    double* tau = d->tmp_nv[6];
    double* wv = d->tmp_nv[2];
    double* wx = d->tmp_nv[3];
    double err = 0.0, kx[6], rx[6] = {0, 0, 0, 0, 0, 0}, hg = S->hg;
    for (i = rf; i < nv; i++) xi[i] = S->xi_bar[i] + hg * V[i];
    if (rf) {
        pc_dexpinv_apply(xi, V, kx);
        for (i = 0; i < 6; i++) rx[i] = xi[i] - S->xi_bar[i] - hg * kx[i];
    }
    pc_integrate(m, S->q, xi, S->qi);
    for (i = 0; i < nv; i++) a[i] = (V[i] - S->V_bar[i]) / hg;
    pc_rnea(m, d, S->qi, V, a, r);
    pc_force(m, d, S->qi, V, S->u, tau);
    for (i = 0; i < nv; i++) r[i] = -hg * (r[i] - tau[i]);
    newton_solve(m, d, r);
    for (i = 0; i < nv; i++) {
        double dV = r[i], dxi = hg * dV - (i < rf ? rx[i] : 0.0);
        double e1 = dV * wv[i], e2 = dxi * wx[i];
        V[i] += dV;
        if (i < rf) xi[i] += dxi;
        err += e1 * e1 + e2 * e2;
    }
    return err / (2.0 * nv);
}

/* Solve one implicit stage for (xi, V); xi, V hold the predictor on entry. */
static int solve_stage(const pc_model_t* m, pc_data_t* d, const stage_t* S, double* xi, double* V) {
    int nv = m->nv, i, it, attempt;
    for (i = 0; i < nv; i++) {
        d->tmp_nv[3][i] = 1.0 / (d->newton.atol + d->newton.rtol * fabs(xi[i]));
        d->tmp_nv[2][i] = 1.0 / (d->newton.atol + d->newton.rtol * fabs(V[i]));
    }
    for (attempt = 0; attempt < 2; attempt++) {
        for (it = 0; it < d->newton.max_iter; it++) {
            double err = newton_iteration(m, d, S, xi, V);
            if (!(err < INFINITY)) break;
            /* accept a correction below 1 (RMS, weighted) after the first, or a first one ten times below */
            if ((it && err <= 1.0) || err <= 1e-2) {
                for (i = m->n_root_v; i < nv; i++) xi[i] = S->xi_bar[i] + S->hg * V[i];
                d->n_newton += it + 1;
                return PC_OK;
            }
        }
        d->n_newton += d->newton.max_iter;
        if (attempt == 0) {
            pc_integrate(m, S->q, xi, S->qi);
            if (newton_matrix(m, d, S->qi, S->hg)) break;
        }
    }
    pc_set_error(d, "Newton did not converge at t = %.9g s (step too large or state non-finite)", S->t);
    return PC_ERR_NEWTON;
}

/* Balance integrand at a stage: [power in - power dissipated, external moment about N's origin, force
 * in N] for the root's wrench u[0:6] (B components) and the input map. */
static void balance(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                    double* g) {
    int i, j;
    double power = 0.0;
    for (j = 0; j < m->nu; j++) {
        double s = 0.0;
        if (m->custom_b) {
            for (i = 0; i < m->nv; i++) s += m->B[(size_t)i * m->nu + j] * v[i];
        } else if (m->u_to_v[j] >= 0) {
            s = v[m->u_to_v[j]];
        }
        power += u[j] * s;
    }
    g[0] = power - pc_spring_power(m, d, v);
    for (i = 1; i < 7; i++) g[i] = 0.0;
    if (m->free_flyer && !m->custom_b) {
        double R[9], F[3], M[3], pF[3];
        quat_to_matrix(q + 3, R);
        mv3(R, u, F);
        mv3(R, u + 3, M);
        cross3(q, F, pF);
        for (i = 0; i < 3; i++) { g[1 + i] = pF[i] + M[i]; g[4 + i] = F[i]; }
    }
    if (d->orbit_n != 0.0) { /* the gravity gradient: its power and its force and moment about N's origin */
        double* tau = d->tmp_nv[7];
        double FM[6];
        memset(tau, 0, (size_t)m->nv * sizeof(double));
        pc_gravity_force(m, d, q, tau, FM);
        for (i = 0; i < m->nv; i++) g[0] += tau[i] * v[i];
        for (i = 0; i < 3; i++) { g[1 + i] += FM[3 + i]; g[4 + i] += FM[i]; }
    }
}

/* the predictor of implicit stage i: the previous steps' same stage (extrapolated), else the last stage */
static void predictor(const pc_model_t* m, const pc_data_t* d, int i, const double* v, double h, double hg, int warm,
                      const pc_stages_t* S, const double* xbar, const double* Vbar, double* xi, double* V) {
    int k, nv = m->nv;
    int same = warm && d->have_prev && d->prev_h == h;
    for (k = 0; k < nv; k++) {
        if (same && d->have_prev == 2) /* the stage's offset from the step's start, extrapolated linearly */
            V[k] = v[k] + 2.0 * (d->prev_V[(size_t)i * nv + k] - d->prev_v[k]) -
                   (d->prev2_V[(size_t)i * nv + k] - d->prev2_v[k]);
        else if (same && d->have_prev)
            V[k] = d->prev_V[(size_t)i * nv + k] + (v[k] - d->prev_v[k]);
        else if (i)
            V[k] = Vbar[k] + hg * S->Kv[i - 1][k];
        else
            V[k] = v[k];
        if (!same && i) xi[k] = xbar[k] + hg * S->Kxi[i - 1][k];
        else if (!same) xi[k] = hg * v[k];
        else xi[k] = xbar[k] + hg * V[k];
    }
}

/* one stage: explicit (evaluated) or implicit (solved); its derivatives Kxi, Kv */
static int one_stage(const pc_model_t* m, pc_data_t* d, int i, const double* q, const double* v, double t, double h,
                     pc_stages_t* S, double* last_hg, int warm, double* xbar) {
    int nv = m->nv, j, k, err;
    double g = m->tab.A[i][i], ti = t + m->tab.c[i] * h;
    double *xi = S->xi[i], *V = S->V[i], *Vbar = xbar + nv;
    for (k = 0; k < nv; k++) { xbar[k] = 0.0; Vbar[k] = v[k]; }
    for (j = 0; j < i; j++) {
        double ha = h * m->tab.A[i][j];
        if (ha == 0.0) continue;
        for (k = 0; k < nv; k++) { xbar[k] += ha * S->Kxi[j][k]; Vbar[k] += ha * S->Kv[j][k]; }
    }
    pc_inputs_at(m, d, ti, m->tab.c[i] == 1.0, S->u[i]);
    pc_orbit_time(d, ti);
    if (g == 0.0) {
        memcpy(xi, xbar, (size_t)nv * sizeof(double));
        memcpy(V, Vbar, (size_t)nv * sizeof(double));
        kxi(m, xi, V, S->Kxi[i]);
        pc_integrate(m, q, xi, d->tmp_nq[0]);
        return pc_accel(m, d, d->tmp_nq[0], V, S->u[i], S->Kv[i]);
    }
    {
        stage_t st = {q, S->u[i], xbar, Vbar, h * g, t, d->tmp_nq[0]};
        if (st.hg != *last_hg) {
            if ((err = newton_matrix(m, d, q, st.hg))) return err;
            *last_hg = st.hg;
        }
        predictor(m, d, i, v, h, st.hg, warm, S, xbar, Vbar, xi, V);
        if ((err = solve_stage(m, d, &st, xi, V))) return err;
        for (k = 0; k < nv; k++) {
            S->Kxi[i][k] = (xi[k] - xbar[k]) / st.hg;
            S->Kv[i][k] = (V[k] - Vbar[k]) / st.hg;
        }
    }
    return PC_OK;
}

/* One step from (q, v) at t; stages left in S. quad (7) accumulates h sum b_i g(stage_i) when given. */
static int step_stages(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double h,
                       pc_stages_t* S, double* xi_end, double* v_end, double* quad, int warm) {
    int nv = m->nv, s = m->tab.s, i, k, err = PC_OK;
    double last_hg = 0.0;
    size_t mark = PC_ARENA_MARK(d);
    double* xbar = pc_arena_alloc(d, 2 * (size_t)nv);
    if (!xbar) return PC_ERR_MEMORY;
    for (i = 0; i < s && !err; i++) err = one_stage(m, d, i, q, v, t, h, S, &last_hg, warm, xbar);
    PC_ARENA_RELEASE(d, mark);
    if (err) return err;
    if (m->tab.stiffly_accurate) {
        memcpy(xi_end, S->xi[s - 1], (size_t)nv * sizeof(double));
        memcpy(v_end, S->V[s - 1], (size_t)nv * sizeof(double));
    } else {
        for (k = 0; k < nv; k++) {
            double a = 0.0, b = 0.0;
            for (i = 0; i < s; i++) { a += m->tab.b[i] * S->Kxi[i][k]; b += m->tab.b[i] * S->Kv[i][k]; }
            xi_end[k] = h * a;
            v_end[k] = v[k] + h * b;
        }
    }
    if (quad) {
        double gi[7];
        for (i = 0; i < s; i++) {
            pc_integrate(m, q, S->xi[i], d->tmp_nq[0]);
            pc_orbit_time(d, t + m->tab.c[i] * h);
            balance(m, d, d->tmp_nq[0], S->V[i], S->u[i], gi);
            for (k = 0; k < 7; k++) quad[k] += h * m->tab.b[i] * gi[k];
        }
    }
    return PC_OK;
}

/* remember this step's stages for the next step's predictor */
static void remember(const pc_model_t* m, pc_data_t* d, const double* v, double h, const pc_stages_t* S) {
    int k, nv = m->nv;
    if (d->have_prev && d->prev_h == h) { /* shift the memory by one step */
        double* t1 = d->prev2_V;
        double* t2 = d->prev2_v;
        d->prev2_V = d->prev_V; d->prev2_v = d->prev_v;
        d->prev_V = t1; d->prev_v = t2;
        d->have_prev = 2;
    } else {
        d->have_prev = 1;
    }
    for (k = 0; k < m->tab.s; k++) memcpy(d->prev_V + (size_t)k * nv, S->V[k], (size_t)nv * sizeof(double));
    memcpy(d->prev_v, v, (size_t)nv * sizeof(double));
    d->prev_h = h;
}

static int finish_step(const pc_model_t* m, pc_data_t* d, double* q, double* v, const double* xi_end,
                       const double* v_end, double t, double h, const pc_stages_t* S) {
    int k, nv = m->nv;
    double* q1 = d->tmp_nq[1];
    pc_integrate(m, q, xi_end, q1);
    for (k = 0; k < m->nq; k++)
        if (!(fabs(q1[k]) < INFINITY)) goto nonfinite;
    for (k = 0; k < nv; k++)
        if (!(fabs(v_end[k]) < INFINITY)) goto nonfinite;
    remember(m, d, v, h, S);
    memcpy(q, q1, (size_t)m->nq * sizeof(double));
    memcpy(v, v_end, (size_t)nv * sizeof(double));
    d->n_steps++;
    return PC_OK;
nonfinite:
    pc_set_error(d, "non-finite state after the step at t = %.9g s", t);
    return PC_ERR_NONFINITE;
}

static int check_state(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double h) {
    int k;
    if (!(fabs(t) < INFINITY) || !(h > 0.0 && h < INFINITY)) {
        pc_set_error(d, "step: t = %g s and h = %g s, expected a finite time and a finite positive step", t, h);
        return PC_ERR_ARG;
    }
    for (k = 0; k < m->nq; k++)
        if (!(fabs(q[k]) < INFINITY)) {
            pc_set_error(d, "q[%d] = %g: expected a finite configuration", k, q[k]);
            return PC_ERR_ARG;
        }
    for (k = 0; k < m->nv; k++)
        if (!(fabs(v[k]) < INFINITY)) {
            pc_set_error(d, "v[%d] = %g: expected a finite velocity", k, v[k]);
            return PC_ERR_ARG;
        }
    return PC_OK;
}

/* One step that leaves its stages in S (allocated by the caller from the arena) and the chart end in xi_end. */
int pc_step_internal(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, pc_stages_t* S,
                     double* xi_end, int warm) {
    size_t mark = PC_ARENA_MARK(d);
    double* v_end = pc_arena_alloc(d, (size_t)m->nv);
    int err;
    if (!v_end) return PC_ERR_MEMORY;
    err = check_state(m, d, q, v, t, h);
    if (!err) err = step_stages(m, d, q, v, t, h, S, xi_end, v_end, NULL, warm);
    if (!err) err = finish_step(m, d, q, v, xi_end, v_end, t, h, S);
    PC_ARENA_RELEASE(d, mark);
    return err;
}

int pc_step(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, double* quad) {
    pc_stages_t S;
    size_t mark = PC_ARENA_MARK(d);
    double* ends;
    int err = pc_stages_alloc(m, d, &S);
    ends = err ? NULL : pc_arena_alloc(d, 2 * (size_t)m->nv);
    if (!ends) {
        PC_ARENA_RELEASE(d, mark);
        return PC_ERR_MEMORY;
    }
    err = check_state(m, d, q, v, t, h);
    if (!err) err = step_stages(m, d, q, v, t, h, &S, ends, ends + m->nv, quad, 1);
    if (!err) err = finish_step(m, d, q, v, ends, ends + m->nv, t, h, &S);
    PC_ARENA_RELEASE(d, mark);
    return err;
}

/* the steps from sample k - 1 to sample k */
static int steps_to_sample(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t_prev, double h,
                           int per_sample, pc_stages_t* S, double* ends, double* quad) {
    int j, err = PC_OK;
    for (j = 0; j < per_sample && !err; j++) {
        double ts = t_prev + j * h;
        err = step_stages(m, d, q, v, ts, h, S, ends, ends + m->nv, quad, 1);
        if (!err) err = finish_step(m, d, q, v, ends, ends + m->nv, ts, h, S);
    }
    return err;
}

/* Samples k0 .. k0 + n_samples - 1 of a run (sample k at t0 + k sample), per_sample steps of h between
 * them, every output recorded; a run may be cut into such calls and gives the same result.
 * Histories are sample-major (the caller transposes): q (nq), v (nv), ddq (nv), panels (4 npanels),
 * mech (11 + nz), the balance integrals (7) and the inputs (nu) at each sample. */
int pc_simulate(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t0, double sample, double h,
                int per_sample, int k0, int n_samples, double* q_hist, double* v_hist, double* a_hist,
                double* panels_hist, double* mech_hist, double* bal_hist, double* u_hist, volatile int* cancel) {
    pc_stages_t S;
    int k, err, nv = m->nv;
    double quad[7];
    size_t mark = PC_ARENA_MARK(d);
    double* ends;
    if (per_sample < 1 || n_samples < 0 || k0 < 0 || !(sample > 0.0)) {
        pc_set_error(d, "simulate: per_sample %d, n_samples %d, k0 %d, sample %g: expected >= 1, >= 0, >= 0, > 0",
                     per_sample, n_samples, k0, sample);
        return PC_ERR_ARG;
    }
    err = check_state(m, d, q, v, t0, h);
    if (err) return err;
    if (pc_stages_alloc(m, d, &S) || !(ends = pc_arena_alloc(d, 2 * (size_t)nv))) {
        PC_ARENA_RELEASE(d, mark);
        return PC_ERR_MEMORY;
    }
    memcpy(quad, bal_hist, sizeof quad); /* continue the balance from the caller's first row */
    for (k = 0; k < n_samples && !err; k++) {
        double t = t0 + (k0 + k) * sample; /* time never accumulates: t0 + (global sample) * sample */
        if (k) err = steps_to_sample(m, d, q, v, t0 + (k0 + k - 1) * sample, h, per_sample, &S, ends, quad);
        if (err) break;
        memcpy(q_hist + (size_t)k * m->nq, q, (size_t)m->nq * sizeof(double));
        memcpy(v_hist + (size_t)k * nv, v, (size_t)nv * sizeof(double));
        err = pc_sample(m, d, q, v, t, a_hist + (size_t)k * nv, panels_hist + (size_t)k * 4 * m->npanels,
                        mech_hist + (size_t)k * (11 + m->nz));
        memcpy(bal_hist + (size_t)k * 7, quad, sizeof quad);
        pc_inputs_at(m, d, t, 0, u_hist + (size_t)k * m->nu);
        if (cancel && *cancel) break;
    }
    PC_ARENA_RELEASE(d, mark);
    return err;
}
