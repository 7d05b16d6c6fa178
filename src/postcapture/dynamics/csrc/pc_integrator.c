/*
 * postcapture plant core: Lie-group diagonally implicit Runge-Kutta steps, their exact Jacobians, the
 * truth loop and the filters' prediction.
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
 * Step Jacobians: the implicit function theorem on every converged stage gives the exact derivative
 * of the step taken with respect to (q_k, v_k) (tangent), a constant input offset and the parameters.
 */
#include <stdlib.h>

#include "pc_internal.h"

static int stages_alloc(const pc_model_t* m, pc_stages_t* S) {
    int i, nv = m->nv, nu = m->nu;
    size_t per = 4 * (size_t)nv + (size_t)nu;
    S->buf = (double*)calloc(per * PC_MAX_STAGES + 1, sizeof(double));
    if (!S->buf) return PC_ERR_MEMORY;
    for (i = 0; i < PC_MAX_STAGES; i++) {
        double* b = S->buf + per * i;
        S->xi[i] = b; S->V[i] = b + nv; S->Kxi[i] = b + 2 * nv; S->Kv[i] = b + 3 * nv; S->u[i] = b + 4 * nv;
    }
    return PC_OK;
}

static void kxi(const pc_model_t* m, const double* xi, const double* V, double* out) {
    memcpy(out, V, (size_t)m->nv * sizeof(double));
    if (m->free_flyer) pc_dexpinv_apply(xi, V, out);
}

/* Newton matrix M(q) + hg D + (hg)^2 K at q: articulated factorization (diagonal springs) or dense LU. */
static int newton_matrix(pc_model_t* m, const double* q, double hg) {
    int nv = m->nv, i, x, y;
    if (m->diag_springs) {
        double* arm = m->tmp_nv[0];
        memset(arm, 0, (size_t)nv * sizeof(double));
        for (i = 0; i < m->ns; i++) {
            const pc_spring_t* S = &m->springs[i];
            arm[S->v[0]] += S->a[0] * S->a[0] * (hg * S->d + hg * hg * S->k);
        }
        return pc_factorize(m, q, arm, &m->fac);
    }
    pc_mass_matrix(m, q, m->dense);
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        for (x = 0; x < 2; x++)
            for (y = 0; y < 2; y++)
                if (S->v[x] >= 0 && S->v[y] >= 0)
                    m->dense[(size_t)S->v[x] * nv + S->v[y]] += S->a[x] * S->a[y] * (hg * S->d + hg * hg * S->k);
    }
    if (pc_lu_factor(m->dense, m->piv, nv)) {
        pc_set_error(m, "singular Newton matrix");
        return PC_ERR_SINGULAR;
    }
    m->fac.valid = 1;
    m->n_factor++;
    return PC_OK;
}

static void newton_solve(pc_model_t* m, double* x) {
    if (m->diag_springs) pc_factor_solve(m, &m->fac, x);
    else pc_lu_solve(m->dense, m->piv, m->nv, x, 1, 1);
}

/* Solve one implicit stage for (xi, V) given xi_bar, V_bar; xi, V hold the predictor on entry. */
static int solve_stage(pc_model_t* m, const double* q, const double* u, const double* xi_bar, const double* V_bar,
                       double hg, double* xi, double* V, double t, double* qi) {
    int nv = m->nv, i, it, attempt, rf = m->n_root_v;
    double* r = m->tmp_nv[4];
    double* a = m->tmp_nv[5];
    double* tau = m->tmp_nv[6];
    double* wv = m->tmp_nv[2];
    double* wx = m->tmp_nv[3];
    double kx[6], inv_n = 1.0 / (2.0 * nv);
    for (i = 0; i < nv; i++) {
        wx[i] = 1.0 / (m->newton.atol + m->newton.rtol * fabs(xi[i]));
        wv[i] = 1.0 / (m->newton.atol + m->newton.rtol * fabs(V[i]));
    }
    for (attempt = 0; attempt < 2; attempt++) {
        for (it = 0; it < m->newton.max_iter; it++) {
            double err = 0.0, rx[6] = {0, 0, 0, 0, 0, 0};
            for (i = rf; i < nv; i++) xi[i] = xi_bar[i] + hg * V[i];
            if (rf) {
                pc_dexpinv_apply(xi, V, kx);
                for (i = 0; i < 6; i++) rx[i] = xi[i] - xi_bar[i] - hg * kx[i];
            }
            pc_integrate(m, q, xi, qi);
            for (i = 0; i < nv; i++) a[i] = (V[i] - V_bar[i]) / hg;
            pc_rnea(m, qi, V, a, r);
            pc_force(m, qi, V, u, tau);
            for (i = 0; i < nv; i++) r[i] = -hg * (r[i] - tau[i]);
            newton_solve(m, r);
            for (i = 0; i < nv; i++) {
                double dV = r[i], dxi = hg * dV - (i < rf ? rx[i] : 0.0);
                double e1 = dV * wv[i], e2 = dxi * wx[i];
                V[i] += dV;
                if (i < rf) xi[i] += dxi;
                err += e1 * e1 + e2 * e2;
            }
            err *= inv_n;
            if (!(err < INFINITY)) break;
            /* accept a correction below 1 (RMS, weighted) after the first, or a first one ten times below */
            if ((it && err <= 1.0) || err <= 1e-2) {
                for (i = rf; i < nv; i++) xi[i] = xi_bar[i] + hg * V[i];
                m->n_newton += it + 1;
                return PC_OK;
            }
        }
        m->n_newton += m->newton.max_iter;
        if (attempt == 0) {
            pc_integrate(m, q, xi, qi);
            if (newton_matrix(m, qi, hg)) break;
        }
    }
    pc_set_error(m, "Newton did not converge at t = %.9g s (step too large or state non-finite)", t);
    return PC_ERR_NEWTON;
}

/* Balance integrand at a stage: [power in - power dissipated, external moment about N's origin, force
 * in N] for the root's wrench u[0:6] (B components) and the input map. */
static void balance(const pc_model_t* m, const double* q, const double* v, const double* u, double* g) {
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
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        double rate = S->a[0] * v[S->v[0]];
        if (S->v[1] >= 0) rate += S->a[1] * v[S->v[1]];
        power -= S->d * rate * rate;
    }
    g[0] = power;
    for (i = 1; i < 7; i++) g[i] = 0.0;
    if (m->free_flyer && !m->custom_b) {
        double R[9], F[3], M[3], pF[3];
        quat_to_matrix(q + 3, R);
        mv3(R, u, F);
        mv3(R, u + 3, M);
        cross3(q, F, pF);
        for (i = 0; i < 3; i++) { g[1 + i] = pF[i] + M[i]; g[4 + i] = F[i]; }
    }
}

/* One step from (q, v) at t; stages left in S. quad (7) accumulates h sum b_i g(stage_i) when given. */
static int step_stages(pc_model_t* m, const double* q, const double* v, double t, double h, pc_stages_t* S,
                       double* xi_end, double* v_end, double* quad, int warm) {
    int nv = m->nv, s = m->tab.s, i, j, k, err;
    double* qi = m->tmp_nq[0];
    double last_hg = 0.0;
    for (i = 0; i < s; i++) {
        double g = m->tab.A[i][i], ti = t + m->tab.c[i] * h;
        double* xi = S->xi[i];
        double* V = S->V[i];
        double* xb = m->tmp_nv[0];
        double* Vb = m->tmp_nv[1];
        for (k = 0; k < nv; k++) { xb[k] = 0.0; Vb[k] = v[k]; }
        for (j = 0; j < i; j++) {
            double ha = h * m->tab.A[i][j];
            if (ha == 0.0) continue;
            for (k = 0; k < nv; k++) { xb[k] += ha * S->Kxi[j][k]; Vb[k] += ha * S->Kv[j][k]; }
        }
        pc_inputs(m, ti, m->tab.c[i] == 1.0, S->u[i]);
        if (g == 0.0) {
            memcpy(xi, xb, (size_t)nv * sizeof(double));
            memcpy(V, Vb, (size_t)nv * sizeof(double));
            kxi(m, xi, V, S->Kxi[i]);
            pc_integrate(m, q, xi, qi);
            if ((err = pc_accel(m, qi, V, S->u[i], S->Kv[i]))) return err;
        } else {
            double hg = h * g, inv = 1.0 / hg;
            /* copies: newton_matrix and solve_stage use the scratch vectors */
            double* xbar = (double*)malloc(2 * (size_t)nv * sizeof(double));
            double* Vbar;
            if (!xbar) return PC_ERR_MEMORY;
            Vbar = xbar + nv;
            memcpy(xbar, xb, (size_t)nv * sizeof(double));
            memcpy(Vbar, Vb, (size_t)nv * sizeof(double));
            if (hg != last_hg) {
                if ((err = newton_matrix(m, q, hg))) { free(xbar); return err; }
                last_hg = hg;
            }
            if (warm && m->have_prev == 2 && m->prev_h == h) {
                /* the stage's offset from the step's start, extrapolated linearly over the last two steps */
                for (k = 0; k < nv; k++) {
                    double d1 = m->prev_V[(size_t)i * nv + k] - m->prev_v[k];
                    double d2 = m->prev2_V[(size_t)i * nv + k] - m->prev2_v[k];
                    V[k] = v[k] + 2.0 * d1 - d2;
                    xi[k] = xbar[k] + hg * V[k];
                }
            } else if (warm && m->have_prev && m->prev_h == h) {
                for (k = 0; k < nv; k++) {
                    V[k] = m->prev_V[(size_t)i * nv + k] + (v[k] - m->prev_v[k]);
                    xi[k] = xbar[k] + hg * V[k];
                }
            } else if (i) {
                for (k = 0; k < nv; k++) { xi[k] = xbar[k] + hg * S->Kxi[i - 1][k]; V[k] = Vbar[k] + hg * S->Kv[i - 1][k]; }
            } else {
                for (k = 0; k < nv; k++) { xi[k] = hg * v[k]; V[k] = v[k]; }
            }
            err = solve_stage(m, q, S->u[i], xbar, Vbar, hg, xi, V, t, qi);
            if (err) { free(xbar); return err; }
            for (k = 0; k < nv; k++) {
                S->Kxi[i][k] = (xi[k] - xbar[k]) * inv;
                S->Kv[i][k] = (V[k] - Vbar[k]) * inv;
            }
            free(xbar);
        }
    }
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
            pc_integrate(m, q, S->xi[i], qi);
            balance(m, qi, S->V[i], S->u[i], gi);
            for (k = 0; k < 7; k++) quad[k] += h * m->tab.b[i] * gi[k];
        }
    }
    return PC_OK;
}

static int finish_step(pc_model_t* m, double* q, double* v, const double* xi_end, const double* v_end, double t, double h,
                       const pc_stages_t* S) {
    int k, nv = m->nv;
    double* q1 = m->tmp_nq[1];
    pc_integrate(m, q, xi_end, q1);
    for (k = 0; k < m->nq; k++)
        if (!(fabs(q1[k]) < INFINITY)) goto nonfinite;
    for (k = 0; k < nv; k++)
        if (!(fabs(v_end[k]) < INFINITY)) goto nonfinite;
    if (m->have_prev && m->prev_h == h) { /* shift the memory by one step */
        double* t1 = m->prev2_V;
        double* t2 = m->prev2_v;
        m->prev2_V = m->prev_V; m->prev2_v = m->prev_v;
        m->prev_V = t1; m->prev_v = t2;
        m->have_prev = 2;
    } else {
        m->have_prev = 1;
    }
    for (k = 0; k < m->tab.s; k++) memcpy(m->prev_V + (size_t)k * nv, S->V[k], (size_t)nv * sizeof(double));
    memcpy(m->prev_v, v, (size_t)nv * sizeof(double));
    m->prev_h = h;
    memcpy(q, q1, (size_t)m->nq * sizeof(double));
    memcpy(v, v_end, (size_t)nv * sizeof(double));
    m->n_steps++;
    return PC_OK;
nonfinite:
    pc_set_error(m, "non-finite state after the step at t = %.9g s", t);
    return PC_ERR_NONFINITE;
}

/* One step that leaves its stages in S (the caller frees S->buf) and the chart end in xi_end. */
int pc_step_internal(pc_model_t* m, double* q, double* v, double t, double h, pc_stages_t* S, double* xi_end, int warm) {
    int err;
    double* v_end;
    if (stages_alloc(m, S)) return PC_ERR_MEMORY;
    v_end = (double*)malloc((size_t)m->nv * sizeof(double));
    if (!v_end) return PC_ERR_MEMORY;
    err = step_stages(m, q, v, t, h, S, xi_end, v_end, NULL, warm);
    if (!err) err = finish_step(m, q, v, xi_end, v_end, t, h, S);
    free(v_end);
    return err;
}

int pc_step(pc_model_t* m, double* q, double* v, double t, double h, double* quad) {
    pc_stages_t S;
    int err;
    double* ends;
    if (stages_alloc(m, &S)) return PC_ERR_MEMORY;
    ends = (double*)malloc(2 * (size_t)m->nv * sizeof(double));
    if (!ends) { free(S.buf); return PC_ERR_MEMORY; }
    err = step_stages(m, q, v, t, h, &S, ends, ends + m->nv, quad, 1);
    if (!err) err = finish_step(m, q, v, ends, ends + m->nv, t, h, &S);
    free(ends);
    free(S.buf);
    return err;
}

/* Samples k0 .. k0 + n_samples - 1 of a run (sample k at t0 + k sample), per_sample steps of h between
 * them, every output recorded; a run may be cut into such calls and gives the same result.
 * Histories are sample-major (the caller transposes): q (nq), v (nv), ddq (nv), panels (4 npanels),
 * mech (11 + nz), the balance integrals (7) and the inputs (nu) at each sample. */
int pc_simulate(pc_model_t* m, double* q, double* v, double t0, double sample, double h, int per_sample, int k0,
                int n_samples,
                double* q_hist, double* v_hist, double* a_hist, double* panels_hist, double* mech_hist,
                double* bal_hist, double* u_hist, volatile int* cancel) {
    pc_stages_t S;
    int k, j, err = PC_OK, nv = m->nv;
    double quad[7];
    double* ends;
    if (stages_alloc(m, &S)) return PC_ERR_MEMORY;
    ends = (double*)malloc(2 * (size_t)nv * sizeof(double));
    if (!ends) { free(S.buf); return PC_ERR_MEMORY; }
    memcpy(quad, bal_hist, sizeof quad); /* continue the balance from the caller's first row */
    for (k = 0; k < n_samples; k++) {
        double t = t0 + (k0 + k) * sample; /* time never accumulates: t0 + (global sample) * sample */
        if (k) {
            for (j = 0; j < per_sample; j++) {
                double ts = t0 + (k0 + k - 1) * sample + j * h;
                err = step_stages(m, q, v, ts, h, &S, ends, ends + nv, quad, 1);
                if (!err) err = finish_step(m, q, v, ends, ends + nv, ts, h, &S);
                if (err) goto done;
            }
        }
        memcpy(q_hist + (size_t)k * m->nq, q, (size_t)m->nq * sizeof(double));
        memcpy(v_hist + (size_t)k * nv, v, (size_t)nv * sizeof(double));
        err = pc_sample(m, q, v, t, a_hist + (size_t)k * nv, panels_hist + (size_t)k * 4 * m->npanels,
                        mech_hist + (size_t)k * (11 + m->nz));
        if (err) goto done;
        memcpy(bal_hist + (size_t)k * 7, quad, sizeof quad);
        pc_inputs(m, t, 0, u_hist + (size_t)k * m->nu);
        if (cancel && *cancel) break;
    }
done:
    free(ends);
    free(S.buf);
    return err;
}
