/*
 * postcapture plant core: the exact step Jacobian and the filters' prediction.
 *
 * Columns of every sensitivity: [dq_k (nv, tangent), dv_k (nv), du (nu, a constant input offset over
 * the step), dp (np)]. Rows of a stage's sensitivity dZ_i: [dxi_i (nv); dV_i (nv)].
 *
 * Stage i, with dZbar_i = base + h sum_j a_ij dK_j (base: identity from v_k into V) and the partials
 * Aq, Av, Au, Ap of the acceleration at the converged stage:
 *   explicit (a_ii = 0): dZ_i = dZbar_i, dK_i from the partials;
 *   implicit (hg = h a_ii): W = (I - hg Av - hg^2 Aq)^-1 (dZbar_V + hg Aq dZbar_xi + hg [Aq 0 Au Ap]),
 *     dxi = dZbar_xi + hg W on the joints and (I - hg Gx)^-1 (dZbar_xi + hg G W) on the free flyer
 *     (Aq has no free-flyer columns without gravity), dK_i = (dZ_i - dZbar_i) / hg.
 * The step's end goes through the tangent maps of q_k (+) xi_end.
 */
#include <stdlib.h>

#include "pc_internal.h"

typedef struct {
    int nv, nt, nc, ncu; /* ncu: input columns carried (nu, or 0 when Fu is not wanted) */
    double *dK, *dZ, *R0, *Aq, *Av, *Au, *Ap, *W, *M, *buf;
} sens_t;

static int sens_alloc(const pc_model_t* m, sens_t* W, int with_inputs) {
    int nv = m->nv, nt = 2 * nv, ncu = with_inputs ? m->nu : 0, nc = nt + ncu + m->np;
    size_t n = (size_t)PC_MAX_STAGES * nt * nc + 3 * (size_t)nt * nc + 3 * (size_t)nv * nv + (size_t)nv * m->nu +
               (size_t)nv * m->np + (size_t)nv * nc + 16;
    W->nv = nv; W->nt = nt; W->nc = nc; W->ncu = ncu;
    W->buf = (double*)calloc(n, sizeof(double));
    if (!W->buf) return PC_ERR_MEMORY;
    W->dK = W->buf;
    W->dZ = W->dK + (size_t)PC_MAX_STAGES * nt * nc;
    W->R0 = W->dZ + (size_t)nt * nc;
    W->Aq = W->R0 + (size_t)nt * nc;
    W->Av = W->Aq + (size_t)nv * nv;
    W->Au = W->Av + (size_t)nv * nv;
    W->Ap = W->Au + (size_t)nv * m->nu;
    W->W = W->Ap + (size_t)nv * m->np;
    W->M = W->W + (size_t)nv * nc;
    return PC_OK;
}

static int stage_sensitivity(pc_model_t* m, sens_t* W, const pc_stages_t* S, int i, const double* q, double h) {
    int nv = W->nv, nt = W->nt, nc = W->nc, nu = m->nu, ncu = W->ncu, np = m->np, rf = m->n_root_v;
    int r, c, k, j, err, base_only = 1;
    double hg = h * m->tab.A[i][i];
    double* dK = W->dK + (size_t)i * nt * nc;
    double* dZ = W->dZ;
    double* R0 = W->R0;
    double* qi = m->tmp_nq[0];
    double G[36], Gx[36];
    pc_integrate(m, q, S->xi[i], qi);
    if (hg == 0.0) /* explicit: the accelerations' partials */
        err = pc_derivatives(m, qi, S->V[i], S->u[i], NULL, W->Aq, W->Av, W->Au, W->Ap);
    else { /* implicit: force form, no inverse mass matrix (Aq <- Cq, Av <- Cv, Ap <- Tp) */
        double* ddq = W->W;
        err = pc_force_partials(m, qi, S->V[i], S->u[i], ddq, W->Aq, W->Av, W->Ap);
        if (!err) err = pc_crba(m, qi, W->M);
    }
    if (err) return err;
    memset(R0, 0, (size_t)nt * nc * sizeof(double));
    for (r = 0; r < nv; r++) R0[(size_t)(nv + r) * nc + nv + r] = 1.0;
    for (j = 0; j < i; j++) {
        double ha = h * m->tab.A[i][j];
        const double* dKj = W->dK + (size_t)j * nt * nc;
        if (ha == 0.0) continue;
        base_only = 0;
        for (k = 0; k < nt * nc; k++) R0[k] += ha * dKj[k];
    }
    if (rf) pc_dexpinv_mats(S->xi[i], S->V[i], G, Gx);
    if (hg == 0.0) {
        memcpy(dZ, R0, (size_t)nt * nc * sizeof(double));
        /* dK = [Gx X + G W (root) | W (joints) ; Aq (X + E_q) + Av W + [0 Au Ap]] */
        for (r = 0; r < nv; r++)
            for (c = 0; c < nc; c++) {
                double s, t = 0.0;
                if (r < rf) {
                    s = 0.0;
                    for (k = 0; k < 6; k++) s += Gx[6 * r + k] * dZ[(size_t)k * nc + c] + G[6 * r + k] * dZ[(size_t)(nv + k) * nc + c];
                } else {
                    s = dZ[(size_t)(nv + r) * nc + c];
                }
                dK[(size_t)r * nc + c] = s;
                for (k = rf; k < nv; k++) t += W->Aq[(size_t)r * nv + k] * dZ[(size_t)k * nc + c];
                for (k = 0; k < nv; k++) t += W->Av[(size_t)r * nv + k] * dZ[(size_t)(nv + k) * nc + c];
                if (c < nv) t += W->Aq[(size_t)r * nv + c];
                else if (c >= nt && c < nt + ncu) t += W->Au[(size_t)r * nu + (c - nt)];
                else if (c >= nt + ncu) t += W->Ap[(size_t)r * np + (c - nt - ncu)];
                dK[(size_t)(nv + r) * nc + c] = t;
            }
        return PC_OK;
    }
    /* velocity sensitivities in force form:
     * (M + hg Cv + hg^2 Cq) W = M dZbar_V - hg Cq dZbar_xi + hg [-Cq 0 B Tp] */
    {
        double* Wm = W->W;
        double* Sm = m->dense;
        const double *M = W->M, *Cq = W->Aq, *Cv = W->Av, *Tp = W->Ap;
        for (r = 0; r < nv; r++) {
            double* Wr = Wm + (size_t)r * nc;
            for (c = 0; c < nc; c++) {
                double s = 0.0;
                if (c < nv) s = -hg * Cq[(size_t)r * nv + c];
                else if (c >= nt && c < nt + ncu) s = hg * m->B[(size_t)r * nu + (c - nt)];
                else if (c >= nt + ncu) s = hg * Tp[(size_t)r * np + (c - nt - ncu)];
                Wr[c] = s;
            }
            if (base_only) { /* dZbar = base: M dZbar_V is M in the dv columns, dZbar_xi = 0 */
                for (k = 0; k < nv; k++) Wr[nv + k] += M[(size_t)r * nv + k];
                continue;
            }
            for (k = 0; k < nv; k++) {
                double a = M[(size_t)r * nv + k];
                const double* Rk = R0 + (size_t)(nv + k) * nc;
                if (a != 0.0)
                    for (c = 0; c < nc; c++) Wr[c] += a * Rk[c];
            }
            for (k = rf; k < nv; k++) {
                double a = -hg * Cq[(size_t)r * nv + k];
                const double* Rk = R0 + (size_t)k * nc;
                if (a != 0.0)
                    for (c = 0; c < nc; c++) Wr[c] += a * Rk[c];
            }
        }
        for (k = 0; k < nv * nv; k++) Sm[k] = M[k] + hg * Cv[k] + hg * hg * Cq[k];
        if (pc_lu_factor(Sm, m->piv, nv)) {
            pc_set_error(m, "singular stage sensitivity matrix");
            return PC_ERR_SINGULAR;
        }
        pc_lu_solve(Sm, m->piv, nv, Wm, nc, nc);
        for (r = 0; r < nv; r++)
            for (c = 0; c < nc; c++) dZ[(size_t)r * nc + c] = R0[(size_t)r * nc + c] + hg * Wm[(size_t)r * nc + c];
        if (rf) {
            double P6[36];
            int piv6[6];
            for (r = 0; r < 6; r++)
                for (c = 0; c < nc; c++) {
                    double s = R0[(size_t)r * nc + c];
                    for (k = 0; k < 6; k++) s += hg * G[6 * r + k] * Wm[(size_t)k * nc + c];
                    dZ[(size_t)r * nc + c] = s;
                }
            for (k = 0; k < 36; k++) P6[k] = -hg * Gx[k];
            for (k = 0; k < 6; k++) P6[6 * k + k] += 1.0;
            if (pc_lu_factor(P6, piv6, 6)) return PC_ERR_SINGULAR;
            pc_lu_solve(P6, piv6, 6, dZ, nc, nc);
        }
        memcpy(dZ + (size_t)nv * nc, Wm, (size_t)nv * nc * sizeof(double));
        for (k = 0; k < nt * nc; k++) dK[k] = (dZ[k] - R0[k]) / hg;
    }
    return PC_OK;
}

/* One step with its Jacobian: Fx (nt x nt), Fu (nt x nu), Fp (nt x np), all row-major. */
static int step_with_jacobian(pc_model_t* m, double* q, double* v, double t, double h, sens_t* W, double* Fx,
                              double* Fu, double* Fp, int warm) {
    int nv = m->nv, nt = 2 * nv, nc = W->nc, s = m->tab.s, nu = m->nu, ncu = W->ncu, np = m->np, rf = m->n_root_v;
    int i, r, c, k, err;
    pc_stages_t S;
    double* xi_end = (double*)malloc((size_t)nv * sizeof(double));
    double* q0 = (double*)malloc((size_t)m->nq * sizeof(double));
    const double* d_end;
    if (!xi_end || !q0) { free(xi_end); free(q0); return PC_ERR_MEMORY; }
    memcpy(q0, q, (size_t)m->nq * sizeof(double));
    err = pc_step_internal(m, q, v, t, h, &S, xi_end, warm);
    if (err) goto out;
    for (i = 0; i < s; i++)
        if ((err = stage_sensitivity(m, W, &S, i, q0, h))) goto out;
    if (m->tab.stiffly_accurate) {
        d_end = W->dZ;
    } else {
        double* e = W->R0;
        memset(e, 0, (size_t)nt * nc * sizeof(double));
        for (r = 0; r < nv; r++) e[(size_t)(nv + r) * nc + nv + r] = 1.0;
        for (i = 0; i < s; i++) {
            const double* dKi = W->dK + (size_t)i * nt * nc;
            for (k = 0; k < nt * nc; k++) e[k] += h * m->tab.b[i] * dKi[k];
        }
        d_end = e;
    }
    /* rows of q_k+1: tangent maps of q_k (+) xi_end */
    {
        double* out = W->W;
        double J0[36], Jr[36];
        memcpy(out, d_end, (size_t)nt * nc * sizeof(double));
        if (rf) {
            pc_dintegrate_root(xi_end, J0, Jr);
            for (r = 0; r < 6; r++)
                for (c = 0; c < nc; c++) {
                    double a = 0.0;
                    for (k = 0; k < 6; k++) a += Jr[6 * r + k] * d_end[(size_t)k * nc + c];
                    if (c < 6) a += J0[6 * r + c];
                    out[(size_t)r * nc + c] = a;
                }
        }
        for (r = rf; r < nv; r++) out[(size_t)r * nc + r] += 1.0;
        for (r = 0; r < nt; r++) {
            if (Fx) memcpy(Fx + (size_t)r * nt, out + (size_t)r * nc, (size_t)nt * sizeof(double));
            if (Fu && ncu) memcpy(Fu + (size_t)r * nu, out + (size_t)r * nc + nt, (size_t)nu * sizeof(double));
            if (Fp && np) memcpy(Fp + (size_t)r * np, out + (size_t)r * nc + nt + ncu, (size_t)np * sizeof(double));
        }
    }
out:
    free(S.buf);
    free(xi_end);
    free(q0);
    return err;
}

int pc_step_jacobian(pc_model_t* m, double* q, double* v, double t, double h, double* F, double* Fu, double* Fp) {
    sens_t W;
    int err;
    if (sens_alloc(m, &W, Fu != NULL)) return PC_ERR_MEMORY;
    err = step_with_jacobian(m, q, v, t, h, &W, F, Fu, Fp, 0);
    free(W.buf);
    return err;
}

/* z and its Jacobians at (q, v, t): H (nz x 2nv), Hu (nz x nu), Hp (nz x np); NULL to skip. */
static int measure_with(pc_model_t* m, const double* q, const double* v, double t, double* z, double* H, double* Hu,
                        double* Hp, const sens_t* W);

int pc_measure(pc_model_t* m, const double* q, const double* v, double t, double* z, double* H, double* Hu,
               double* Hp) {
    return measure_with(m, q, v, t, z, H, Hu, Hp, NULL);
}

/* With W (the last step's sensitivities, whose last implicit stage sits at (q, v) with the same inputs)
 * the force-form partials of that stage are reused instead of recomputed. */
static int measure_with(pc_model_t* m, const double* q, const double* v, double t, double* z, double* H, double* Hu,
                        double* Hp, const sens_t* W) {
    int nv = m->nv, nu = m->nu, np = m->np, nz = m->nz, nt = 2 * nv, r, c, k, err;
    double* u = (double*)malloc(((size_t)nu + 1) * sizeof(double));
    double* ddq = (double*)malloc((size_t)nv * sizeof(double));
    double *Aq = NULL, *Av = NULL, *Au = NULL, *Ap = NULL;
    if (!u || !ddq) { free(u); free(ddq); return PC_ERR_MEMORY; }
    pc_inputs(m, t, 0, u);
    if (!(H || Hu || Hp)) {
        err = pc_accel(m, q, v, u, ddq);
        if (!err) pc_measurement(m, q, v, ddq, z);
        free(u); free(ddq);
        return err;
    }
    Aq = (double*)malloc((2 * (size_t)nv * nv + (size_t)nv * nu + (size_t)nv * np + 1) * sizeof(double));
    if (!Aq) { free(u); free(ddq); return PC_ERR_MEMORY; }
    Av = Aq + (size_t)nv * nv; Au = Av + (size_t)nv * nv; Ap = Au + (size_t)nv * nu;
    {
        /* only the root's and the arm's rows of the partials enter z: rows 0..5 then arm_v */
        int rows[6 + 64], nr = 0, jr;
        if (m->n_arm_v > 64 || !m->free_flyer) { err = PC_ERR_ARG; pc_set_error(m, "measurement: needs a free-flyer root and at most 64 arm joints"); goto out; }
        for (jr = 0; jr < 6; jr++) rows[nr++] = jr;
        for (jr = 0; jr < m->n_arm_v; jr++) rows[nr++] = m->arm_v[jr];
        if (W) {
            err = pc_accel(m, q, v, u, ddq);
            if (!err) err = pc_rows_from_partials(m, q, W->Aq, W->Av, W->Ap, rows, nr, Aq, Av, Hu ? Au : NULL, Ap);
        } else {
            err = pc_derivative_rows(m, q, v, u, rows, nr, ddq, Aq, Av, Hu ? Au : NULL, Ap);
        }
        if (err) goto out;
    }
    pc_measurement(m, q, v, ddq, z);
    {
        /* accel = ddq[0:3] + w x vl + dw x r + w x (w x r): d/d ddq[0:6] = [I, -[r]x] */
        const double* rr = m->r_acc;
        const double* w = v + 3;
        const double* vl = v;
        double Jd[18] = {1, 0, 0, 0, rr[2], -rr[1], 0, 1, 0, -rr[2], 0, rr[0], 0, 0, 1, rr[1], -rr[0], 0};
        double wr = w[0] * rr[0] + w[1] * rr[1] + w[2] * rr[2];
        double dvl[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
        double dw[9];
        for (r = 0; r < 3; r++)
            for (c = 0; c < 3; c++) dw[3 * r + c] = w[r] * rr[c] - 2.0 * rr[r] * w[c] + (r == c ? wr : 0.0);
        dw[1] += vl[2]; dw[2] -= vl[1]; dw[3] -= vl[2]; dw[5] += vl[0]; dw[6] += vl[1]; dw[7] -= vl[0];
#define ROWS3(X, ncol, OUT)                                                                   \
    for (r = 0; r < 3; r++)                                                                   \
        for (c = 0; c < (ncol); c++) {                                                        \
            double s = 0.0;                                                                   \
            for (k = 0; k < 6; k++) s += Jd[6 * r + k] * (X)[(size_t)k * (ncol) + c];         \
            (OUT)[(size_t)r * (ncol) + c] = s;                                                \
        }
        if (H) {
            memset(H, 0, (size_t)nz * nt * sizeof(double));
            for (r = 0; r < 3; r++)
                for (c = 0; c < nv; c++) {
                    double s1 = 0.0, s2 = 0.0;
                    for (k = 0; k < 6; k++) {
                        s1 += Jd[6 * r + k] * Aq[(size_t)k * nv + c];
                        s2 += Jd[6 * r + k] * Av[(size_t)k * nv + c];
                    }
                    H[(size_t)r * nt + c] = s1;
                    H[(size_t)r * nt + nv + c] = s2;
                }
            if (m->free_flyer)
                for (r = 0; r < 3; r++)
                    for (c = 0; c < 3; c++) {
                        H[(size_t)r * nt + nv + c] += dvl[3 * r + c];
                        H[(size_t)r * nt + nv + 3 + c] += dw[3 * r + c];
                    }
            for (r = 0; r < m->n_arm_v; r++) {
                memcpy(H + (size_t)(3 + r) * nt, Aq + (size_t)(6 + r) * nv, (size_t)nv * sizeof(double));
                memcpy(H + (size_t)(3 + r) * nt + nv, Av + (size_t)(6 + r) * nv, (size_t)nv * sizeof(double));
            }
        }
        if (Hu) {
            memset(Hu, 0, (size_t)nz * nu * sizeof(double));
            ROWS3(Au, nu, Hu)
            for (r = 0; r < m->n_arm_v; r++) memcpy(Hu + (size_t)(3 + r) * nu, Au + (size_t)(6 + r) * nu, (size_t)nu * sizeof(double));
        }
        if (Hp && np) {
            memset(Hp, 0, (size_t)nz * np * sizeof(double));
            ROWS3(Ap, np, Hp)
            for (r = 0; r < m->n_arm_v; r++) memcpy(Hp + (size_t)(3 + r) * np, Ap + (size_t)(6 + r) * np, (size_t)np * sizeof(double));
        }
#undef ROWS3
    }
out:
    free(Aq);
    free(u);
    free(ddq);
    return err;
}

/* n_steps steps of h from (q, v, t), then the measurement at the end; with want_jac the accumulated
 * step Jacobians (F nt x nt, Fu nt x nu, Fp nt x np) and the measurement Jacobians. */
int pc_predict(pc_model_t* m, double* q, double* v, double t, double h, int n_steps, int want_jac, double* z,
               double* F, double* Fu, double* Fp, double* H, double* Hu, double* Hp) {
    int nv = m->nv, nt = 2 * nv, nu = Fu ? m->nu : 0, np = m->np, j, r, c, k, err = PC_OK;
    sens_t W;
    double *Fs = NULL, *Fus = NULL, *Fps = NULL, *T = NULL;
    m->have_prev = 0;
    if (!want_jac) {
        for (j = 0; j < n_steps && !err; j++) err = pc_step(m, q, v, t + j * h, h, NULL);
        if (!err) err = pc_measure(m, q, v, t + n_steps * h, z, NULL, NULL, NULL);
        return err;
    }
    if (sens_alloc(m, &W, Fu != NULL)) return PC_ERR_MEMORY;
    Fs = (double*)malloc(((size_t)nt * nt + (size_t)nt * nu + (size_t)nt * np + (size_t)nt * (nt + nu + np) + 1) * sizeof(double));
    if (!Fs) { free(W.buf); return PC_ERR_MEMORY; }
    Fus = Fs + (size_t)nt * nt; Fps = Fus + (size_t)nt * nu; T = Fps + (size_t)nt * np;
    for (j = 0; j < n_steps; j++) {
        double* ox = j ? Fs : F;
        double* ou = Fu ? (j ? Fus : Fu) : NULL;
        double* op = j ? Fps : Fp;
        err = step_with_jacobian(m, q, v, t + j * h, h, &W, ox, ou, op, j > 0);
        if (err) goto out;
        if (j) { /* chain: F <- Fs F, Fu <- Fs Fu + Fus, Fp <- Fs Fp + Fps */
            int ncol = nt + nu + np;
            for (r = 0; r < nt; r++)
                for (c = 0; c < ncol; c++) {
                    double s = c < nt ? 0.0 : (c < nt + nu ? Fus[(size_t)r * nu + c - nt] : Fps[(size_t)r * np + c - nt - nu]);
                    for (k = 0; k < nt; k++) {
                        double a = Fs[(size_t)r * nt + k];
                        double b = c < nt ? F[(size_t)k * nt + c] : (c < nt + nu ? Fu[(size_t)k * nu + c - nt] : Fp[(size_t)k * np + c - nt - nu]);
                        s += a * b;
                    }
                    T[(size_t)r * ncol + c] = s;
                }
            for (r = 0; r < nt; r++) {
                memcpy(F + (size_t)r * nt, T + (size_t)r * ncol, (size_t)nt * sizeof(double));
                if (nu) memcpy(Fu + (size_t)r * nu, T + (size_t)r * ncol + nt, (size_t)nu * sizeof(double));
                if (np) memcpy(Fp + (size_t)r * np, T + (size_t)r * ncol + nt + nu, (size_t)np * sizeof(double));
            }
        }
    }
    {
        /* the last stage of a stiffly accurate method with c = 1 is the measurement point; its partials
         * serve when the inputs there have no jump (left limit = value) */
        const sens_t* reuse = NULL;
        int s_last = m->tab.s - 1;
        if (m->tab.stiffly_accurate && m->tab.c[s_last] == 1.0 && m->tab.A[s_last][s_last] != 0.0) {
            double* ul = (double*)malloc(2 * ((size_t)m->nu + 1) * sizeof(double));
            if (ul) {
                int same = 1, i;
                pc_inputs(m, t + n_steps * h, 1, ul);
                pc_inputs(m, t + n_steps * h, 0, ul + m->nu + 1);
                for (i = 0; i < m->nu; i++) same &= ul[i] == ul[m->nu + 1 + i];
                if (same) reuse = &W;
                free(ul);
            }
        }
        err = measure_with(m, q, v, t + n_steps * h, z, H, Hu, Hp, reuse);
    }
out:
    free(Fs);
    free(W.buf);
    return err;
}
