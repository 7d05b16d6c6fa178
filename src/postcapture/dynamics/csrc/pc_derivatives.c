/*
 * postcapture plant core: exact partial derivatives of the forward dynamics.
 *
 * With ddq = M(q)^-1 (tau(q, v, u, p) - b(q, v)) and the inverse dynamics ID(q, v, a) = M a + b,
 *
 *     d ddq / dx = M^-1 (d tau / dx - d ID / dx |_(a = ddq)),
 *
 * for x = q (tangent), v, u and the parameters p. The inverse-dynamics partials come from a tangent
 * (forward-mode) pass of the recursive Newton-Euler algorithm per direction, restricted to the subtree
 * of the perturbed joint and the chain of its ancestors (joints are numbered depth first, so a subtree
 * is a contiguous range). Without gravity the root's configuration does not enter ID.
 */
#include <stdlib.h>

#include "pc_internal.h"

/* One tangent direction: joint j's angle (mode 0), joint j's rate (mode 1), or root rate component k
 * (mode 2, j = 0). Writes d ID / d(direction) into col (nv). V, A, F: the RNEA's twists, accelerations
 * and subtree wrenches; C: joint bias accelerations; dv, da, dF: scratch (nj x 6). */
static void tangent_rnea(const pc_model_t* m, const int* sub_end, const double* V, const double* A, const double* F,
                         const double* Cb, const double* IV, const double* v, int mode, int j, int k, double* dv,
                         double* da, double* dF, double* col) {
    int c, r;
    int end = sub_end[j];
    memset(col, 0, (size_t)m->nv * sizeof(double));
    for (c = j; c < end; c++) {
        const pc_joint_t* J = &m->joints[c];
        double* dvc = dv + 6 * c;
        double* dac = da + 6 * c;
        double Idv[6], t1[6], t2[6], t3[6];
        if (c == j) {
            if (mode == 2) {
                memset(dvc, 0, 6 * sizeof(double));
                dvc[k] = 1.0;
                memset(dac, 0, 6 * sizeof(double));
            } else {
                double S[6] = {0, 0, 0, 0, 0, 0}, vS[6];
                S[3 + J->kind] = 1.0;
                cross_motion(V + 6 * c, S, vS);
                if (mode == 1) {
                    memcpy(dvc, S, sizeof S);
                    memcpy(dac, vS, sizeof vS);
                } else {
                    double amc[6], vSS[6];
                    for (r = 0; r < 6; r++) amc[r] = A[6 * c + r] - Cb[6 * c + r];
                    memcpy(dvc, vS, sizeof vS);
                    cross_motion(amc, S, dac);
                    cross_motion(vS, S, vSS);
                    for (r = 0; r < 6; r++) dac[r] += v[J->iv] * vSS[r];
                }
            }
        } else {
            double Sq[6] = {0, 0, 0, 0, 0, 0}, x[6];
            motion_act_inv(m->Rl + 9 * c, m->pl + 3 * c, dv + 6 * J->parent, dvc);
            motion_act_inv(m->Rl + 9 * c, m->pl + 3 * c, da + 6 * J->parent, dac);
            Sq[3 + J->kind] = v[J->iv];
            cross_motion(dvc, Sq, x);
            for (r = 0; r < 6; r++) dac[r] += x[r];
        }
        /* body wrench tangent: I da + dv x* (I v) + v x* (I dv) */
        inertia_mul(J->pi, dac, t1);
        cross_force(dvc, IV + 6 * c, t2); /* I v of the body, the same for every direction */
        inertia_mul(J->pi, dvc, Idv);
        cross_force(V + 6 * c, Idv, t3);
        for (r = 0; r < 6; r++) dF[6 * c + r] = t1[r] + t2[r] + t3[r];
    }
    for (c = end - 1; c >= j; c--) {
        const pc_joint_t* J = &m->joints[c];
        if (J->kind < 0) memcpy(col + J->iv, dF + 6 * c, 6 * sizeof(double));
        else col[J->iv] = dF[6 * c + 3 + J->kind];
        if (c > j) {
            double f[6];
            force_act(m->Rl + 9 * c, m->pl + 3 * c, dF + 6 * c, f);
            for (r = 0; r < 6; r++) dF[6 * J->parent + r] += f[r];
        }
    }
    /* up the chain of ancestors */
    {
        double G[6], up[6];
        int cur = j, par = m->joints[j].parent;
        memcpy(G, dF + 6 * j, sizeof G);
        if (mode == 0) {
            double S[6] = {0, 0, 0, 0, 0, 0}, x[6];
            S[3 + m->joints[j].kind] = 1.0;
            cross_force(S, F + 6 * j, x);
            for (r = 0; r < 6; r++) G[r] += x[r];
        }
        while (par >= 0) {
            const pc_joint_t* P = &m->joints[par];
            force_act(m->Rl + 9 * cur, m->pl + 3 * cur, G, up);
            if (P->kind < 0) {
                for (r = 0; r < 6; r++) col[P->iv + r] += up[r];
            } else {
                col[P->iv] += up[3 + P->kind];
            }
            memcpy(G, up, sizeof G);
            cur = par;
            par = P->parent;
        }
    }
}

/* The subtree range of every joint (joints must be numbered depth first). */
static int subtree_ends(const pc_model_t* m, int* sub_end) {
    int i;
    for (i = 0; i < m->nj; i++) sub_end[i] = i + 1;
    for (i = m->nj - 1; i >= 0; i--) {
        int p = m->joints[i].parent;
        if (p >= 0 && sub_end[i] > sub_end[p]) sub_end[p] = sub_end[i];
    }
    for (i = 0; i < m->nj; i++) {
        int c;
        for (c = i + 1; c < sub_end[i]; c++) {
            int a = m->joints[c].parent;
            while (a > i) a = m->joints[a].parent;
            if (a != i) return 1;
        }
    }
    return 0;
}

/* d ID / dq (tangent) and d ID / dv at (q, v, a), nv x nv row-major. */
int pc_rnea_derivatives(pc_model_t* m, const double* q, const double* v, const double* a, double* dq, double* dv) {
    int nv = m->nv, nj = m->nj, i, r;
    double* tau = m->tmp_nv[3];
    double* col = m->tmp_nv[2];
    int* sub_end = (int*)malloc((size_t)nj * sizeof(int));
    double* buf = (double*)malloc((size_t)nj * 6 * 8 * sizeof(double));
    double *V, *A, *F, *Cb, *tv, *ta, *tF, *IV;
    if (!sub_end || !buf) {
        free(sub_end); free(buf);
        return PC_ERR_MEMORY;
    }
    if (subtree_ends(m, sub_end)) {
        free(sub_end); free(buf);
        pc_set_error(m, "joints are not numbered depth first");
        return PC_ERR_ARG;
    }
    V = buf; A = V + 6 * nj; F = A + 6 * nj; Cb = F + 6 * nj; tv = Cb + 6 * nj; ta = tv + 6 * nj; tF = ta + 6 * nj;
    IV = tF + 6 * nj;
    pc_rnea(m, q, v, a, tau);
    memcpy(V, m->vj, (size_t)nj * 6 * sizeof(double));
    memcpy(A, m->aj, (size_t)nj * 6 * sizeof(double));
    memcpy(F, m->fj, (size_t)nj * 6 * sizeof(double));
    memcpy(Cb, m->cj, (size_t)nj * 6 * sizeof(double));
    for (i = 0; i < nj; i++) inertia_mul(m->joints[i].pi, V + 6 * i, IV + 6 * i);
    if (dq) memset(dq, 0, (size_t)nv * nv * sizeof(double));
    for (i = 0; i < nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        if (J->kind < 0) {
            int k;
            if (!dv) continue;
            for (k = 0; k < 6; k++) {
                tangent_rnea(m, sub_end, V, A, F, Cb, IV, v, 2, i, k, tv, ta, tF, col);
                for (r = 0; r < nv; r++) dv[(size_t)r * nv + J->iv + k] = col[r];
            }
            continue;
        }
        if (dq) {
            tangent_rnea(m, sub_end, V, A, F, Cb, IV, v, 0, i, 0, tv, ta, tF, col);
            for (r = 0; r < nv; r++) dq[(size_t)r * nv + J->iv] = col[r];
        }
        if (dv) {
            tangent_rnea(m, sub_end, V, A, F, Cb, IV, v, 1, i, 0, tv, ta, tF, col);
            for (r = 0; r < nv; r++) dv[(size_t)r * nv + J->iv] = col[r];
        }
    }
    free(sub_end);
    free(buf);
    return PC_OK;
}

/* d(tau - ID)/dp at (q, v, a) for every parameter, nv x np row-major: the target's ten inertial
 * parameters through the joint carrying the target, the spring and damper scales through the springs.
 * Needs the RNEA twists and accelerations of (q, v, a) in the workspace (call after pc_rnea). */
void pc_param_forces(pc_model_t* m, const double* q, const double* v, const double* a, double* Tp) {
    int nv = m->nv, np = m->np, i, k, r, off = m->nq - m->nv;
    (void)a;
    memset(Tp, 0, (size_t)nv * np * sizeof(double));
    if (m->target_joint >= 0) {
        int tj = m->target_joint;
        const double* vt = m->vj + 6 * tj;
        const double* at = m->aj + 6 * tj;
        for (k = 0; k < 10; k++) {
            double pi[10], f[6], Iv[6], b[6], up[6];
            int cur = tj, par;
            for (r = 0; r < 10; r++) pi[r] = m->t_L[10 * r + k];
            inertia_mul(pi, at, f);
            inertia_mul(pi, vt, Iv);
            cross_force(vt, Iv, b);
            for (r = 0; r < 6; r++) f[r] = -(f[r] + b[r]);
            while (cur >= 0) {
                const pc_joint_t* J = &m->joints[cur];
                if (J->kind < 0) {
                    for (r = 0; r < 6; r++) Tp[(size_t)(J->iv + r) * np + k] += f[r];
                } else {
                    Tp[(size_t)J->iv * np + k] += f[3 + J->kind];
                }
                par = J->parent;
                if (par >= 0) {
                    force_act(m->Rl + 9 * cur, m->pl + 3 * cur, f, up);
                    memcpy(f, up, sizeof f);
                }
                cur = par;
            }
        }
    }
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        double defl = S->a[0] * q[S->v[0] + off] - S->rest, rate = S->a[0] * v[S->v[0]];
        if (S->v[1] >= 0) {
            defl += S->a[1] * q[S->v[1] + off];
            rate += S->a[1] * v[S->v[1]];
        }
        for (r = 0; r < 2; r++) {
            if (S->v[r] < 0) continue;
            if (S->pk >= 0) Tp[(size_t)S->v[r] * np + S->pk] += -S->k0 * defl * S->a[r];
            if (S->pd >= 0) Tp[(size_t)S->v[r] * np + S->pd] += -S->d0 * rate * S->a[r];
        }
    }
}

/* The joint-space mass matrix by the composite-rigid-body algorithm, nv x nv row-major. */
int pc_crba(pc_model_t* m, const double* q, double* M) {
    int nv = m->nv, i, k, r;
    pc_kinematics(m, q);
    memset(M, 0, (size_t)nv * nv * sizeof(double));
    for (i = 0; i < m->nj; i++) pc_joint_inertia_matrix(m->joints[i].pi, m->IA + 36 * i);
    for (i = m->nj - 1; i >= 0; i--) {
        const pc_joint_t* J = &m->joints[i];
        const double* Ic = m->IA + 36 * i;
        int ncol = J->kind < 0 ? 6 : 1;
        for (k = 0; k < ncol; k++) {
            double F[6], up[6];
            int col = J->iv + k, cur = i, par;
            for (r = 0; r < 6; r++) F[r] = Ic[6 * r + (J->kind < 0 ? k : 3 + J->kind)];
            while (cur >= 0) {
                const pc_joint_t* C = &m->joints[cur];
                if (C->kind < 0) {
                    for (r = 0; r < 6; r++) M[(size_t)(C->iv + r) * nv + col] = F[r];
                } else {
                    M[(size_t)C->iv * nv + col] = F[3 + C->kind];
                }
                par = C->parent;
                if (par >= 0) {
                    force_act(m->Rl + 9 * cur, m->pl + 3 * cur, F, up);
                    memcpy(F, up, sizeof F);
                }
                cur = par;
            }
        }
        if (J->parent >= 0) pc_add_transformed_inertia(m->Rl + 9 * i, m->pl + 3 * i, Ic, m->IA + 36 * J->parent);
    }
    for (i = 0; i < nv; i++)
        for (k = 0; k < i; k++) M[(size_t)i * nv + k] = M[(size_t)k * nv + i];
    return PC_OK;
}

/* Force-form partials at (q, v, u): ddq, Cq = d(ID - tau)/dq (tangent), Cv = d(ID - tau)/dv at a = ddq
 * (nv x nv), and Tp = d(tau - ID)/dp (nv x np); any of Cq, Cv, Tp may be NULL. */
int pc_force_partials(pc_model_t* m, const double* q, const double* v, const double* u, double* ddq, double* Cq,
                      double* Cv, double* Tp) {
    int nv = m->nv, i, err;
    err = pc_accel(m, q, v, u, ddq);
    if (err) return err;
    if (Cq || Cv) {
        err = pc_rnea_derivatives(m, q, v, ddq, Cq, Cv);
        if (err) return err;
        for (i = 0; i < m->ns; i++) {
            const pc_spring_t* S = &m->springs[i];
            int x, y;
            for (x = 0; x < 2; x++)
                for (y = 0; y < 2; y++) {
                    if (S->v[x] < 0 || S->v[y] < 0) continue;
                    if (Cq) Cq[(size_t)S->v[x] * nv + S->v[y]] += S->k * S->a[x] * S->a[y];
                    if (Cv) Cv[(size_t)S->v[x] * nv + S->v[y]] += S->d * S->a[x] * S->a[y];
                }
        }
    }
    if (Tp && m->np) {
        double* tau = m->tmp_nv[3];
        pc_rnea(m, q, v, ddq, tau);
        pc_param_forces(m, q, v, ddq, Tp);
    }
    return PC_OK;
}

/* ddq and its partials (row-major): Aq (nv x nv, tangent), Av (nv x nv), Au (nv x nu), Ap (nv x np).
 * Any output may be NULL. */
int pc_derivatives(pc_model_t* m, const double* q, const double* v, const double* u, double* ddq, double* Aq,
                   double* Av, double* Au, double* Ap) {
    int nv = m->nv, nu = m->nu, np = m->np, i, r, err;
    double* col = m->tmp_nv[1];
    double* Tp = NULL;
    pc_factor_t F;
    double* own = (double*)malloc((size_t)nv * sizeof(double));
    if (!own) return PC_ERR_MEMORY;
    if (!ddq) ddq = own;
    if (Ap && np) {
        Tp = (double*)malloc((size_t)nv * np * sizeof(double));
        if (!Tp) { free(own); return PC_ERR_MEMORY; }
    }
    err = pc_force_partials(m, q, v, u, ddq, Aq, Av, Tp);
    if (err) { free(Tp); free(own); return err; }
    for (i = 0; i < nv * nv; i++) {
        if (Aq) Aq[i] = -Aq[i];
        if (Av) Av[i] = -Av[i];
    }
    /* multiply every column by M^-1 with the articulated factorization at q */
    F.R = m->jac_work; F.p = F.R + 9 * m->nj; F.U = F.p + 3 * m->nj; F.Dinv = F.U + 6 * m->nj; F.cs = F.Dinv + m->nj; F.valid = 0;
    err = pc_factorize(m, q, NULL, &F);
    m->n_factor--; /* not an integrator factorization */
    if (err) { free(Tp); free(own); return err; }
#define SOLVE_COLUMNS(X, ncol, skip)                                                        \
    for (i = 0; i < (ncol); i++) {                                                         \
        if (skip) continue;                                                                 \
        for (r = 0; r < nv; r++) col[r] = (X)[(size_t)r * (ncol) + i];                      \
        pc_factor_solve(m, &F, col);                                                        \
        for (r = 0; r < nv; r++) (X)[(size_t)r * (ncol) + i] = col[r];                      \
    }
    if (Aq) { SOLVE_COLUMNS(Aq, nv, i < m->n_root_v) }
    if (Av) { SOLVE_COLUMNS(Av, nv, 0) }
    if (Au) {
        memcpy(Au, m->B, (size_t)nv * nu * sizeof(double));
        SOLVE_COLUMNS(Au, nu, 0)
    }
    if (Ap && np) {
        memcpy(Ap, Tp, (size_t)nv * np * sizeof(double));
        SOLVE_COLUMNS(Ap, np, 0)
    }
#undef SOLVE_COLUMNS
    free(Tp);
    free(own);
    return PC_OK;
}

/* Rows `rows` (nr of them) of the partials of ddq at q from the force-form partials Cq, Cv, Tp: Aq, Av
 * (nr x nv), Au (nr x nu, when given), Ap (nr x np), with the same rows of M^-1 (columns of the
 * symmetric inverse, one O(n) solve each). */
int pc_rows_from_partials(pc_model_t* m, const double* q, const double* Cq, const double* Cv, const double* Tp,
                          const int* rows, int nr, double* Aq, double* Av, double* Au, double* Ap) {
    int nv = m->nv, nu = m->nu, np = m->np, i, k, c, err;
    double* mr = (double*)malloc((size_t)nv * sizeof(double));
    pc_factor_t F;
    if (!mr) return PC_ERR_MEMORY;
    F.R = m->jac_work; F.p = F.R + 9 * m->nj; F.U = F.p + 3 * m->nj; F.Dinv = F.U + 6 * m->nj; F.cs = F.Dinv + m->nj; F.valid = 0;
    err = pc_factorize(m, q, NULL, &F);
    m->n_factor--;
    if (err) { free(mr); return err; }
    for (i = 0; i < nr; i++) {
        memset(mr, 0, (size_t)nv * sizeof(double));
        mr[rows[i]] = 1.0;
        pc_factor_solve(m, &F, mr);
        for (c = 0; c < nv; c++) {
            double a = 0.0, b = 0.0;
            for (k = 0; k < nv; k++) { a += mr[k] * Cq[(size_t)k * nv + c]; b += mr[k] * Cv[(size_t)k * nv + c]; }
            Aq[(size_t)i * nv + c] = -a;
            Av[(size_t)i * nv + c] = -b;
        }
        if (Au)
            for (c = 0; c < nu; c++) {
                double a = 0.0;
                for (k = 0; k < nv; k++) a += mr[k] * m->B[(size_t)k * nu + c];
                Au[(size_t)i * nu + c] = a;
            }
        for (c = 0; c < np; c++) {
            double a = 0.0;
            for (k = 0; k < nv; k++) a += mr[k] * Tp[(size_t)k * np + c];
            Ap[(size_t)i * np + c] = a;
        }
    }
    free(mr);
    return PC_OK;
}

/* The same from (q, v, u): the force-form partials are computed first. */
int pc_derivative_rows(pc_model_t* m, const double* q, const double* v, const double* u, const int* rows, int nr,
                       double* ddq, double* Aq, double* Av, double* Au, double* Ap) {
    int nv = m->nv, np = m->np, err;
    double* Cq = (double*)malloc((2 * (size_t)nv * nv + (size_t)nv * (np + 1)) * sizeof(double));
    if (!Cq) return PC_ERR_MEMORY;
    err = pc_force_partials(m, q, v, u, ddq, Cq, Cq + (size_t)nv * nv, Cq + 2 * (size_t)nv * nv);
    if (!err) err = pc_rows_from_partials(m, q, Cq, Cq + (size_t)nv * nv, Cq + 2 * (size_t)nv * nv, rows, nr, Aq, Av, Au, Ap);
    free(Cq);
    return err;
}
