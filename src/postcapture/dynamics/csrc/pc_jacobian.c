/*
 * postcapture plant core: exact step Jacobians and the filters' prediction. Owns the stage
 * sensitivities (the implicit function theorem at every converged stage), the step Jacobian through
 * the tangent maps of q_k (+) xi_end, the measurement z and its Jacobians, and pc_predict: n steps, the
 * measurement and, on request, every Jacobian chained over the steps, in one call.
 *
 * Columns of every sensitivity: [dq_k (nv, tangent), dv_k (nv), du (nu, a constant input offset over
 * the step), dp (np)]. Rows of a stage's sensitivity dZ_i: [dxi_i (nv); dV_i (nv)].
 *
 * Stage i, with dZbar_i = base + h sum_j a_ij dK_j (base: identity from v_k into V) and the partials
 * Aq, Av, Au, Ap of the acceleration at the converged stage:
 *   explicit (a_ii = 0): dZ_i = dZbar_i, dK_i from the partials;
 *   implicit (hg = h a_ii), in force form with M, Cq, Cv, Tp at the stage:
 *     (M + hg Cv + hg^2 Cq) W = M dZbar_V - hg Cq dZbar_xi + hg [-Cq 0 B Tp],
 *     dxi = dZbar_xi + hg W on the joints and (I - hg Gx)^-1 (dZbar_xi + hg G W) on the free flyer
 *     (Cq has no free-flyer columns without gravity), dV = W, dK_i = (dZ_i - dZbar_i) / hg.
 */
#include "pc_internal.h"

typedef struct {
    int nv, nt, nc, ncu; /* ncu: input columns carried (nu, or 0 when Fu is not wanted) */
    double *dK, *dZ, *R0, *Aq, *Av, *Au, *Ap, *W, *M;
} sens_t;

static int sens_alloc(const pc_model_t* m, pc_data_t* d, sens_t* W, int with_inputs) {
    int nv = m->nv, nt = 2 * nv, ncu = with_inputs ? m->nu : 0, nc = nt + ncu + m->np;
    size_t n = (size_t)(PC_MAX_STAGES + 3) * nt * nc + 3 * (size_t)nv * nv + (size_t)nv * m->nu +
               (size_t)nv * m->np + (size_t)nv * nc + 16;
    W->nv = nv; W->nt = nt; W->nc = nc; W->ncu = ncu;
    W->dK = pc_arena_alloc(d, n);
    if (!W->dK) return PC_ERR_MEMORY;
    W->dZ = W->dK + (size_t)PC_MAX_STAGES * nt * nc;
    W->R0 = W->dZ + (size_t)nt * nc;
    W->Aq = W->R0 + (size_t)nt * nc;
    W->Av = W->Aq + (size_t)nv * nv;
    W->Au = W->Av + (size_t)nv * nv;
    W->Ap = W->Au + (size_t)nv * m->nu;
    W->W = W->Ap + (size_t)nv * m->np;
    W->M = W->W + (size_t)nt * nc; /* W also holds the step output (nt x nc) */
    return PC_OK;
}

/* y += a x over n entries (distinct arrays) */
static void axpy(double* restrict y, const double* restrict x, double a, int n) {
    int c;
    for (c = 0; c < n; c++) y[c] += a * x[c];
}

/* R0 = base + h sum_j a_ij dK_j; returns 1 when R0 is the base alone */
static int stage_base(const pc_model_t* m, sens_t* W, int i, double h) {
    int j, r, base_only = 1;
    size_t n = (size_t)W->nt * W->nc;
    memset(W->R0, 0, n * sizeof(double));
    for (r = 0; r < W->nv; r++) W->R0[(size_t)(W->nv + r) * W->nc + W->nv + r] = 1.0;
    for (j = 0; j < i; j++) {
        double ha = h * m->tab.A[i][j];
        const double* dKj = W->dK + (size_t)j * n;
        if (ha == 0.0) continue;
        base_only = 0;
        axpy(W->R0, dKj, ha, (int)n);
    }
    return base_only;
}

/* explicit stage: dZ = R0; dK = [Gx dZ_xi + G dZ_V (root) | dZ_V (joints) ; Aq (dZ_xi + E_q) + Av dZ_V + [0 Au Ap]] */
static void explicit_sensitivity(const pc_model_t* m, sens_t* W, double* dK, const double* G, const double* Gx) {
    int nv = W->nv, nt = W->nt, nc = W->nc, nu = m->nu, np = m->np, ncu = W->ncu, rf = m->n_root_v, r, c, k;
    const double* dZ = W->dZ;
    memcpy(W->dZ, W->R0, (size_t)nt * nc * sizeof(double));
    for (r = 0; r < nv; r++)
        for (c = 0; c < nc; c++) {
            double s = 0.0, t = 0.0;
            if (r < rf)
                for (k = 0; k < 6; k++) s += Gx[6 * r + k] * dZ[(size_t)k * nc + c] + G[6 * r + k] * dZ[(size_t)(nv + k) * nc + c];
            else
                s = dZ[(size_t)(nv + r) * nc + c];
            dK[(size_t)r * nc + c] = s;
            for (k = rf; k < nv; k++) t += W->Aq[(size_t)r * nv + k] * dZ[(size_t)k * nc + c];
            for (k = 0; k < nv; k++) t += W->Av[(size_t)r * nv + k] * dZ[(size_t)(nv + k) * nc + c];
            if (c < nv) t += W->Aq[(size_t)r * nv + c];
            else if (c >= nt && c < nt + ncu) t += W->Au[(size_t)r * nu + (c - nt)];
            else if (c >= nt + ncu) t += W->Ap[(size_t)r * np + (c - nt - ncu)];
            dK[(size_t)(nv + r) * nc + c] = t;
        }
}

/* right-hand side of the implicit stage: M dZbar_V - hg Cq dZbar_xi + hg [-Cq 0 B Tp] (into W->W) */
static void implicit_rhs(const pc_model_t* m, sens_t* W, double hg, int base_only) {
    int nv = W->nv, nt = W->nt, nc = W->nc, nu = m->nu, np = m->np, ncu = W->ncu, rf = m->n_root_v, r, c, k;
    const double *M = W->M, *Cq = W->Aq, *Tp = W->Ap, *R0 = W->R0;
    for (r = 0; r < nv; r++) {
        double* Wr = W->W + (size_t)r * nc;
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
            if (a != 0.0) axpy(Wr, R0 + (size_t)(nv + k) * nc, a, nc);
        }
        for (k = rf; k < nv; k++) {
            double a = -hg * Cq[(size_t)r * nv + k];
            if (a != 0.0) axpy(Wr, R0 + (size_t)k * nc, a, nc);
        }
    }
}

/* dxi on the free flyer: (I - hg Gx)^-1 (dZbar_xi + hg G W) */
static int root_chart(const pc_model_t* m, sens_t* W, double hg, const double* G, const double* Gx) {
    double P6[36];
    int piv6[6], r, c, k, nc = W->nc;
    (void)m;
    for (r = 0; r < 6; r++)
        for (c = 0; c < nc; c++) {
            double s = W->R0[(size_t)r * nc + c];
            for (k = 0; k < 6; k++) s += hg * G[6 * r + k] * W->W[(size_t)k * nc + c];
            W->dZ[(size_t)r * nc + c] = s;
        }
    for (k = 0; k < 36; k++) P6[k] = -hg * Gx[k];
    for (k = 0; k < 6; k++) P6[6 * k + k] += 1.0;
    if (pc_lu_factor(P6, piv6, 6)) return PC_ERR_SINGULAR;
    pc_lu_solve(P6, piv6, 6, W->dZ, nc, nc);
    return PC_OK;
}

static int implicit_sensitivity(const pc_model_t* m, pc_data_t* d, sens_t* W, double* dK, double hg, int base_only,
                                const double* G, const double* Gx) {
    int nv = W->nv, nt = W->nt, nc = W->nc, r, c, k;
    double* Sm = d->dense2;
    implicit_rhs(m, W, hg, base_only);
    for (k = 0; k < nv * nv; k++) Sm[k] = W->M[k] + hg * W->Av[k] + hg * hg * W->Aq[k];
    if (pc_lu_factor(Sm, d->piv, nv)) {
        pc_set_error(d, "singular stage sensitivity matrix");
        return PC_ERR_SINGULAR;
    }
    pc_lu_solve(Sm, d->piv, nv, W->W, nc, nc);
    for (r = 0; r < nv; r++)
        for (c = 0; c < nc; c++) W->dZ[(size_t)r * nc + c] = W->R0[(size_t)r * nc + c] + hg * W->W[(size_t)r * nc + c];
    if (m->n_root_v && root_chart(m, W, hg, G, Gx)) {
        pc_set_error(d, "singular chart map of the free flyer");
        return PC_ERR_SINGULAR;
    }
    memcpy(W->dZ + (size_t)nv * nc, W->W, (size_t)nv * nc * sizeof(double));
    {
        const double inv = 1.0 / hg;
        for (k = 0; k < nt * nc; k++) dK[k] = (W->dZ[k] - W->R0[k]) * inv;
    }
    return PC_OK;
}

static int stage_sensitivity(const pc_model_t* m, pc_data_t* d, sens_t* W, const pc_stages_t* S, int i,
                             const double* q, double h) {
    double hg = h * m->tab.A[i][i], G[36], Gx[36];
    double* dK = W->dK + (size_t)i * W->nt * W->nc;
    double* qi = d->tmp_nq[0];
    int err, base_only;
    pc_integrate(m, q, S->xi[i], qi);
    if (hg == 0.0) /* explicit: the accelerations' partials */
        err = pc_derivatives(m, d, qi, S->V[i], S->u[i], NULL, W->Aq, W->Av, W->Au, W->Ap);
    else { /* implicit: force form, no inverse mass matrix (Aq <- Cq, Av <- Cv, Ap <- Tp) */
        err = pc_force_partials(m, d, qi, S->V[i], S->u[i], W->W, W->Aq, W->Av, W->Ap);
        if (!err) err = pc_crba(m, d, qi, W->M);
    }
    if (err) return err;
    base_only = stage_base(m, W, i, h);
    if (m->n_root_v) pc_dexpinv_mats(S->xi[i], S->V[i], G, Gx);
    if (hg == 0.0) {
        explicit_sensitivity(m, W, dK, G, Gx);
        return PC_OK;
    }
    return implicit_sensitivity(m, d, W, dK, hg, base_only, G, Gx);
}

/* the step's end: d_end = dZ of the last stage (stiffly accurate) or base + h sum b_i dK_i */
static const double* step_end(const pc_model_t* m, sens_t* W, double h) {
    int i, k, r, s = m->tab.s;
    size_t n = (size_t)W->nt * W->nc;
    double* e = W->R0;
    if (m->tab.stiffly_accurate) return W->dZ;
    memset(e, 0, n * sizeof(double));
    for (r = 0; r < W->nv; r++) e[(size_t)(W->nv + r) * W->nc + W->nv + r] = 1.0;
    for (i = 0; i < s; i++) {
        const double* dKi = W->dK + (size_t)i * n;
        for (k = 0; k < (int)n; k++) e[k] += h * m->tab.b[i] * dKi[k];
    }
    return e;
}

/* rows of q_k+1 through the tangent maps of q_k (+) xi_end; split into Fx, Fu, Fp */
static void step_output(const pc_model_t* m, sens_t* W, const double* d_end, const double* xi_end, double* Fx,
                        double* Fu, double* Fp) {
    int nv = m->nv, nt = W->nt, nc = W->nc, nu = m->nu, np = m->np, ncu = W->ncu, r, c, k;
    double* out = W->W;
    double J0[36], Jr[36];
    memcpy(out, d_end, (size_t)nt * nc * sizeof(double));
    if (m->n_root_v) {
        pc_dintegrate_root(xi_end, J0, Jr);
        for (r = 0; r < 6; r++)
            for (c = 0; c < nc; c++) {
                double a = 0.0;
                for (k = 0; k < 6; k++) a += Jr[6 * r + k] * d_end[(size_t)k * nc + c];
                if (c < 6) a += J0[6 * r + c];
                out[(size_t)r * nc + c] = a;
            }
    }
    for (r = m->n_root_v; r < nv; r++) out[(size_t)r * nc + r] += 1.0;
    for (r = 0; r < nt; r++) {
        if (Fx) memcpy(Fx + (size_t)r * nt, out + (size_t)r * nc, (size_t)nt * sizeof(double));
        if (Fu && ncu) memcpy(Fu + (size_t)r * nu, out + (size_t)r * nc + nt, (size_t)nu * sizeof(double));
        if (Fp && np) memcpy(Fp + (size_t)r * np, out + (size_t)r * nc + nt + ncu, (size_t)np * sizeof(double));
    }
}

/* One step with its Jacobian: Fx (nt x nt), Fu (nt x nu), Fp (nt x np), all row-major. */
static int step_with_jacobian(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, sens_t* W,
                              double* Fx, double* Fu, double* Fp, int warm) {
    int i, err;
    pc_stages_t S;
    size_t mark = PC_ARENA_MARK(d);
    double* xi_end = pc_arena_alloc(d, (size_t)m->nv + (size_t)m->nq);
    double* q0 = xi_end + m->nv;
    if (!xi_end || pc_stages_alloc(m, d, &S)) {
        PC_ARENA_RELEASE(d, mark);
        return PC_ERR_MEMORY;
    }
    memcpy(q0, q, (size_t)m->nq * sizeof(double));
    err = pc_step_internal(m, d, q, v, t, h, &S, xi_end, warm);
    for (i = 0; i < m->tab.s && !err; i++) err = stage_sensitivity(m, d, W, &S, i, q0, h);
    if (!err) step_output(m, W, step_end(m, W, h), xi_end, Fx, Fu, Fp);
    PC_ARENA_RELEASE(d, mark);
    return err;
}

int pc_step_jacobian(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, double* F,
                     double* Fu, double* Fp) {
    sens_t W;
    size_t mark = PC_ARENA_MARK(d);
    int err = sens_alloc(m, d, &W, Fu != NULL);
    if (!err) err = step_with_jacobian(m, d, q, v, t, h, &W, F, Fu, Fp, 0);
    PC_ARENA_RELEASE(d, mark);
    return err;
}

/* ------------------------------------------------------------------------------------ measurement */
/* H, Hu, Hp from the rows (root 0..5, then the arm's) of the acceleration partials */
static void measurement_jacobians(const pc_model_t* m, const double* v, const double* Aq, const double* Av,
                                  const double* Au, const double* Ap, double* H, double* Hu, double* Hp) {
    int nv = m->nv, nu = m->nu, np = m->np, nz = m->nz, nt = 2 * nv, r, c, k;
    const double* rr = m->r_acc;
    const double* w = v + 3;
    /* accel = ddq[0:3] + w x vl + dw x r + w x (w x r): d/d ddq[0:6] = [I, -[r]x] */
    double Jd[18] = {1, 0, 0, 0, rr[2], -rr[1], 0, 1, 0, -rr[2], 0, rr[0], 0, 0, 1, rr[1], -rr[0], 0};
    double wr = w[0] * rr[0] + w[1] * rr[1] + w[2] * rr[2];
    double dvl[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0}, dw[9];
    const double* X[4] = {Aq, Av, Au, Ap};
    double* OUT[4] = {H, H ? H + nv : NULL, Hu, Hp};
    int ncol[4] = {nv, nv, nu, np}, ld[4] = {nt, nt, nu, np}, b;
    for (r = 0; r < 3; r++)
        for (c = 0; c < 3; c++) dw[3 * r + c] = w[r] * rr[c] - 2.0 * rr[r] * w[c] + (r == c ? wr : 0.0);
    dw[1] += v[2]; dw[2] -= v[1]; dw[3] -= v[2]; dw[5] += v[0]; dw[6] += v[1]; dw[7] -= v[0];
    if (H) memset(H, 0, (size_t)nz * nt * sizeof(double));
    if (Hu) memset(Hu, 0, (size_t)nz * nu * sizeof(double));
    if (Hp) memset(Hp, 0, (size_t)nz * np * sizeof(double));
    for (b = 0; b < 4; b++) {
        if (!OUT[b] || !X[b] || !ncol[b]) continue;
        for (r = 0; r < 3; r++)
            for (c = 0; c < ncol[b]; c++) {
                double s = 0.0;
                for (k = 0; k < 6; k++) s += Jd[6 * r + k] * X[b][(size_t)k * ncol[b] + c];
                OUT[b][(size_t)r * ld[b] + c] = s;
            }
        for (r = 0; r < m->n_arm_v; r++)
            memcpy(OUT[b] + (size_t)(3 + r) * ld[b], X[b] + (size_t)(6 + r) * ncol[b], (size_t)ncol[b] * sizeof(double));
    }
    if (H)
        for (r = 0; r < 3; r++)
            for (c = 0; c < 3; c++) {
                H[(size_t)r * nt + nv + c] += dvl[3 * r + c];
                H[(size_t)r * nt + nv + 3 + c] += dw[3 * r + c];
            }
}

/* z and its Jacobians at (q, v, t): H (nz x 2nv), Hu (nz x nu), Hp (nz x np); NULL to skip. With W (the
 * last step's sensitivities, whose last implicit stage sits at (q, v) with the same inputs) the
 * force-form partials of that stage are reused instead of recomputed. */
static int measure_with(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double* z,
                        double* H, double* Hu, double* Hp, const sens_t* W) {
    int nv = m->nv, nu = m->nu, np = m->np, nr = 6 + m->n_arm_v, jr, err;
    size_t mark = PC_ARENA_MARK(d);
    double* u = pc_arena_alloc(d, (size_t)nu + 1 + (size_t)nv);
    double *ddq = u ? u + nu + 1 : NULL, *Aq, *Av, *Au, *Ap;
    int* rows;
    if (!u) return PC_ERR_MEMORY;
    pc_inputs_at(m, d, t, 0, u);
    pc_orbit_time(d, t);
    if (!(H || Hu || Hp)) {
        err = pc_accel(m, d, q, v, u, ddq);
        if (!err) pc_measurement(m, v, ddq, z);
        PC_ARENA_RELEASE(d, mark);
        return err;
    }
    if (!m->free_flyer) {
        pc_set_error(d, "measurement Jacobians: the model has no free-flyer root to carry the accelerometer");
        PC_ARENA_RELEASE(d, mark);
        return PC_ERR_ARG;
    }
    Aq = pc_arena_alloc(d, (size_t)nr * (2 * nv + nu + np) + (size_t)nr);
    if (!Aq) { PC_ARENA_RELEASE(d, mark); return PC_ERR_MEMORY; }
    Av = Aq + (size_t)nr * nv; Au = Av + (size_t)nr * nv; Ap = Au + (size_t)nr * nu;
    rows = (int*)(Ap + (size_t)nr * np);
    /* only the root's and the arm's rows of the partials enter z: rows 0..5 then arm_v */
    for (jr = 0; jr < 6; jr++) rows[jr] = jr;
    for (jr = 0; jr < m->n_arm_v; jr++) rows[6 + jr] = m->arm_v[jr];
    if (W) {
        err = pc_accel(m, d, q, v, u, ddq);
        if (!err) err = pc_rows_from_partials(m, d, q, W->Aq, W->Av, W->Ap, rows, nr, Aq, Av, Hu ? Au : NULL, Ap);
    } else {
        err = pc_derivative_rows(m, d, q, v, u, rows, nr, ddq, Aq, Av, Hu ? Au : NULL, Ap);
    }
    if (!err) {
        pc_measurement(m, v, ddq, z);
        measurement_jacobians(m, v, Aq, Av, Hu ? Au : NULL, Ap, H, Hu, Hp);
    }
    PC_ARENA_RELEASE(d, mark);
    return err;
}

int pc_measure(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double* z, double* H,
               double* Hu, double* Hp) {
    return measure_with(m, d, q, v, t, z, H, Hu, Hp, NULL);
}

/* ------------------------------------------------------------------------------------ prediction */
/* F <- Fs F, Fu <- Fs Fu + Fus, Fp <- Fs Fp + Fps (T: nt x (nt + nu + np) scratch), row by row: each row of
 * the product is a sum of the rows of [F Fu Fp] weighted by one row of Fs (contiguous, vectorised) */
static void chain(int nt, int nu, int np, const double* Fs, const double* Fus, const double* Fps, double* F, double* Fu,
                  double* Fp, double* T) {
    int ncol = nt + nu + np, r, k;
    for (r = 0; r < nt; r++) {
        double* Tr = T + (size_t)r * ncol;
        memset(Tr, 0, (size_t)nt * sizeof(double));
        if (nu) memcpy(Tr + nt, Fus + (size_t)r * nu, (size_t)nu * sizeof(double));
        if (np) memcpy(Tr + nt + nu, Fps + (size_t)r * np, (size_t)np * sizeof(double));
        for (k = 0; k < nt; k++) {
            double a = Fs[(size_t)r * nt + k];
            if (a == 0.0) continue;
            axpy(Tr, F + (size_t)k * nt, a, nt);
            if (nu) axpy(Tr + nt, Fu + (size_t)k * nu, a, nu);
            if (np) axpy(Tr + nt + nu, Fp + (size_t)k * np, a, np);
        }
    }
    for (r = 0; r < nt; r++) {
        memcpy(F + (size_t)r * nt, T + (size_t)r * ncol, (size_t)nt * sizeof(double));
        if (nu) memcpy(Fu + (size_t)r * nu, T + (size_t)r * ncol + nt, (size_t)nu * sizeof(double));
        if (np) memcpy(Fp + (size_t)r * np, T + (size_t)r * ncol + nt + nu, (size_t)np * sizeof(double));
    }
}

/* the last stage of a stiffly accurate method with c = 1 is the measurement point; its partials serve
 * when the inputs there have no jump (left limit = value) */
static int reusable_last_stage(const pc_model_t* m, pc_data_t* d, double t_end) {
    int s = m->tab.s - 1, i, same = 1;
    size_t mark = PC_ARENA_MARK(d);
    double* ul;
    if (!(m->tab.stiffly_accurate && m->tab.c[s] == 1.0 && m->tab.A[s][s] != 0.0)) return 0;
    ul = pc_arena_alloc(d, 2 * ((size_t)m->nu + 1));
    if (!ul) return 0;
    pc_inputs_at(m, d, t_end, 1, ul);
    pc_inputs_at(m, d, t_end, 0, ul + m->nu + 1);
    for (i = 0; i < m->nu; i++) same &= ul[i] == ul[m->nu + 1 + i];
    PC_ARENA_RELEASE(d, mark);
    return same;
}

/* the step Jacobians a prediction accumulates: F, Fu, Fp (the caller's) and Fs, Fus, Fps (one step's) */
typedef struct {
    int nt, nu, np, frozen;
    double *F, *Fu, *Fp, *Fs, *Fus, *Fps, *T;
} chain_t;

/* step j: its own Jacobian into the total (j = 0) or into the one-step blocks then chained; frozen: only
 * step 0 is differentiated, its Jacobian kept in the one-step blocks and chained for every later step */
static int jacobian_step(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, int j,
                         sens_t* W, chain_t* C) {
    int err, nt = C->nt;
    if (C->frozen && j) return pc_step(m, d, q, v, t, h, NULL);
    if (!j) {
        err = step_with_jacobian(m, d, q, v, t, h, W, C->F, C->Fu, C->Fp, 0);
        if (!err && C->frozen) {
            memcpy(C->Fs, C->F, (size_t)nt * nt * sizeof(double));
            if (C->nu) memcpy(C->Fus, C->Fu, (size_t)nt * C->nu * sizeof(double));
            if (C->np) memcpy(C->Fps, C->Fp, (size_t)nt * C->np * sizeof(double));
        }
        return err;
    }
    return step_with_jacobian(m, d, q, v, t, h, W, C->Fs, C->Fu ? C->Fus : NULL, C->Fps, 1);
}

/* frozen: the first step's Jacobian taken for every step (F <- F1^n, Fp <- (I + F1 + ... + F1^(n-1)) Fp1):
 * one step's sensitivities instead of n, the mean still stepped exactly */
static int predict_jacobians(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, int n_steps,
                             int frozen, double* z, double* F, double* Fu, double* Fp, double* H, double* Hu,
                             double* Hp) {
    int j, err = PC_OK;
    sens_t W;
    chain_t C = {2 * m->nv, Fu ? m->nu : 0, m->np, frozen, F, Fu, Fp, NULL, NULL, NULL, NULL};
    size_t nt = (size_t)C.nt;
    if (sens_alloc(m, d, &W, Fu != NULL)) return PC_ERR_MEMORY;
    C.Fs = pc_arena_alloc(d, nt * nt + nt * C.nu + nt * C.np + nt * (nt + C.nu + C.np) + 1);
    if (!C.Fs) return PC_ERR_MEMORY;
    C.Fus = C.Fs + nt * nt; C.Fps = C.Fus + nt * C.nu; C.T = C.Fps + nt * C.np;
    for (j = 0; j < n_steps && !err; j++) {
        err = jacobian_step(m, d, q, v, t + j * h, h, j, &W, &C);
        if (!err && j) chain(C.nt, C.nu, C.np, C.Fs, C.Fus, C.Fps, F, Fu, Fp, C.T);
    }
    if (err) return err;
    return measure_with(m, d, q, v, t + n_steps * h, z, H, Hu, Hp,
                        !(frozen && n_steps > 1) && reusable_last_stage(m, d, t + n_steps * h) ? &W : NULL);
}

/* n_steps steps of h from (q, v, t), then the measurement at the end; with want_jac the accumulated
 * step Jacobians (F nt x nt, Fu nt x nu, Fp nt x np) and the measurement Jacobians. A prediction
 * starts cold (no warm start from earlier calls), so it depends on its arguments only. */
int pc_predict(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, int n_steps, int want_jac,
               double* z, double* F, double* Fu, double* Fp, double* H, double* Hu, double* Hp) {
    int j, err = PC_OK;
    size_t mark = PC_ARENA_MARK(d);
    if (n_steps < 1) {
        pc_set_error(d, "prediction: %d steps, expected at least 1", n_steps);
        return PC_ERR_ARG;
    }
    d->have_prev = 0;
    if (want_jac) {
        err = predict_jacobians(m, d, q, v, t, h, n_steps, want_jac == 2, z, F, Fu, Fp, H, Hu, Hp);
    } else {
        for (j = 0; j < n_steps && !err; j++) err = pc_step(m, d, q, v, t + j * h, h, NULL);
        if (!err) err = measure_with(m, d, q, v, t + n_steps * h, z, NULL, NULL, NULL, NULL);
    }
    PC_ARENA_RELEASE(d, mark);
    return err;
}
