/*
 * postcapture plant core: exact partial derivatives of the forward dynamics. Owns
 *
 *     d ddq / dx = M^-1 (d tau / dx - d ID / dx |_(a = ddq)),
 *
 * for x = q (tangent), v, u and the parameters p, from the inverse-dynamics partials
 * (pc_rnea_derivatives.c), the springs' (pc_passive.c) and the parameters' (pc_rnea.c), either as
 * whole matrices (M^-1 applied column by column with the articulated factorization) or as selected
 * rows (rows of M^-1 by O(n) solves: the measurement needs only the root's and the arm's).
 */
#include "pc_internal.h"

/* Force-form partials at (q, v, u): ddq, Cq = d(ID - tau)/dq (tangent), Cv = d(ID - tau)/dv at a = ddq
 * (nv x nv), and Tp = d(tau - ID)/dp (nv x np); any of Cq, Cv, Tp may be NULL. */
int pc_force_partials(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                      double* ddq, double* Cq, double* Cv, double* Tp) {
    int err = pc_accel(m, d, q, v, u, ddq);
    if (err) return err;
    if (Cq || Cv) {
        err = pc_rnea_derivatives(m, d, q, v, ddq, Cq, Cv);
        if (err) return err;
        pc_spring_partials(m, d, Cq, Cv);
    }
    if (Tp && m->np) {
        double* tau = d->tmp_nv[3];
        pc_rnea(m, d, q, v, ddq, tau);
        pc_param_forces(m, d, q, v, Tp);
    }
    return PC_OK;
}

/* X (nv x ncol) <- M^-1 X with a factorization, columns skipped below `first` */
static void solve_columns(const pc_model_t* m, pc_data_t* d, const pc_factor_t* F, double* X, int ncol, int first) {
    double* col = d->tmp_nv[1];
    int i, r, nv = m->nv;
    for (i = first; i < ncol; i++) {
        for (r = 0; r < nv; r++) col[r] = X[(size_t)r * ncol + i];
        pc_factor_solve(m, d, F, col);
        for (r = 0; r < nv; r++) X[(size_t)r * ncol + i] = col[r];
    }
}

/* ddq and its partials (row-major): Aq (nv x nv, tangent), Av (nv x nv), Au (nv x nu), Ap (nv x np).
 * Any output may be NULL. */
int pc_derivatives(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u, double* ddq,
                   double* Aq, double* Av, double* Au, double* Ap) {
    int nv = m->nv, np = m->np, i, err;
    size_t mark = PC_ARENA_MARK(d);
    double* own = pc_arena_alloc(d, (size_t)nv + (size_t)nv * np);
    double* Tp = (Ap && np) ? own + nv : NULL;
    if (!own) return PC_ERR_MEMORY;
    if (!ddq) ddq = own;
    err = pc_force_partials(m, d, q, v, u, ddq, Aq, Av, Tp);
    if (!err) err = pc_factorize(m, d, q, NULL, &d->fac2);
    if (err) {
        PC_ARENA_RELEASE(d, mark);
        return err;
    }
    for (i = 0; i < nv * nv; i++) {
        if (Aq) Aq[i] = -Aq[i];
        if (Av) Av[i] = -Av[i];
    }
    if (Aq) solve_columns(m, d, &d->fac2, Aq, nv, m->n_root_v); /* the root's q columns are zero */
    if (Av) solve_columns(m, d, &d->fac2, Av, nv, 0);
    if (Au) {
        memcpy(Au, m->B, (size_t)nv * m->nu * sizeof(double));
        solve_columns(m, d, &d->fac2, Au, m->nu, 0);
    }
    if (Tp) {
        memcpy(Ap, Tp, (size_t)nv * np * sizeof(double));
        solve_columns(m, d, &d->fac2, Ap, np, 0);
    }
    PC_ARENA_RELEASE(d, mark);
    return PC_OK;
}

/* out (nr x ncol) row i = -(or +) mr . X for the rows of M^-1 in mr */
static void row_times(const double* mr, const double* restrict X, int nv, int ncol, double sign, double* restrict out) {
    int c, k;
    for (c = 0; c < ncol; c++) out[c] = 0.0;
    for (k = 0; k < nv; k++) {
        double a = sign * mr[k];
        const double* restrict Xk = X + (size_t)k * ncol;
        if (a != 0.0)
            for (c = 0; c < ncol; c++) out[c] += a * Xk[c];
    }
}

/* Rows `rows` (nr of them) of the partials of ddq at q from the force-form partials Cq, Cv, Tp: Aq, Av
 * (nr x nv), Au (nr x nu, when given), Ap (nr x np), with the same rows of M^-1 (columns of the
 * symmetric inverse, one O(n) solve each). */
int pc_rows_from_partials(const pc_model_t* m, pc_data_t* d, const double* q, const double* Cq, const double* Cv,
                          const double* Tp, const int* rows, int nr, double* Aq, double* Av, double* Au, double* Ap) {
    int nv = m->nv, nu = m->nu, np = m->np, i, err;
    double* mr = d->tmp_nv[0];
    err = pc_factorize(m, d, q, NULL, &d->fac2);
    if (err) return err;
    for (i = 0; i < nr; i++) {
        memset(mr, 0, (size_t)nv * sizeof(double));
        mr[rows[i]] = 1.0;
        pc_factor_solve(m, d, &d->fac2, mr);
        row_times(mr, Cq, nv, nv, -1.0, Aq + (size_t)i * nv);
        row_times(mr, Cv, nv, nv, -1.0, Av + (size_t)i * nv);
        if (Au) row_times(mr, m->B, nv, nu, 1.0, Au + (size_t)i * nu);
        if (np) row_times(mr, Tp, nv, np, 1.0, Ap + (size_t)i * np);
    }
    return PC_OK;
}

/* The same from (q, v, u): the force-form partials are computed first. */
int pc_derivative_rows(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                       const int* rows, int nr, double* ddq, double* Aq, double* Av, double* Au, double* Ap) {
    int nv = m->nv, np = m->np, err;
    size_t mark = PC_ARENA_MARK(d);
    double* Cq = pc_arena_alloc(d, 2 * (size_t)nv * nv + (size_t)nv * (np + 1));
    if (!Cq) return PC_ERR_MEMORY;
    err = pc_force_partials(m, d, q, v, u, ddq, Cq, Cq + (size_t)nv * nv, Cq + 2 * (size_t)nv * nv);
    if (!err)
        err = pc_rows_from_partials(m, d, q, Cq, Cq + (size_t)nv * nv, Cq + 2 * (size_t)nv * nv, rows, nr, Aq, Av, Au, Ap);
    PC_ARENA_RELEASE(d, mark);
    return err;
}
