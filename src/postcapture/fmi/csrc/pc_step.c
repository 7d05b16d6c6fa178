/*
 * postcapture FMU runtime: Lie-group Runge-Kutta step and its exact step Jacobian.
 *
 * It mirrors postcapture.dynamics.integrators.LieRungeKutta: Runge-Kutta-Munthe-Kaas in the chart
 * q = q_k (+) xi, dexpinv truncated after the ad^2 term, the same tableau, stage inputs taken at
 * t_k + c_i h (left limit when c_i == 1), simplified Newton on the reduced nv x nv system with the
 * matrix I - hg d(ddq)/dv - (hg)^2 d(ddq)/dq at the step's start, iterated to round-off. The step
 * Jacobian differentiates every converged stage (implicit function theorem) as the native one does.
 * Matrices from CasADi are column-major; the runtime's own are row-major.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pc_core.h"

#define NQ PC_NQ
#define NV PC_NV
#define NT PC_NT
#define CM(A, nrows, r, c) ((A)[(c) * (nrows) + (r)]) /* column-major element */

/* ------------------------------------------------------------------------------------ algebra */
static int lu_factor(double* A, int* piv, int n) {
    int i, j, k;
    for (k = 0; k < n; k++) {
        int p = k;
        double big = fabs(A[k * n + k]);
        for (i = k + 1; i < n; i++)
            if (fabs(A[i * n + k]) > big) { big = fabs(A[i * n + k]); p = i; }
        piv[k] = p;
        if (big == 0.0 || !(big < INFINITY)) return 1;
        if (p != k)
            for (j = 0; j < n; j++) { double t = A[k * n + j]; A[k * n + j] = A[p * n + j]; A[p * n + j] = t; }
        for (i = k + 1; i < n; i++) {
            double f = A[i * n + k] / A[k * n + k];
            A[i * n + k] = f;
            for (j = k + 1; j < n; j++) A[i * n + j] -= f * A[k * n + j];
        }
    }
    return 0;
}

/* Solve in place for B (n x m, row-major, leading dimension ld). */
static void lu_solve(const double* LU, const int* piv, int n, double* B, int m, int ld) {
    int i, j, k;
    for (k = 0; k < n; k++)
        if (piv[k] != k)
            for (j = 0; j < m; j++) { double t = B[k * ld + j]; B[k * ld + j] = B[piv[k] * ld + j]; B[piv[k] * ld + j] = t; }
    for (i = 1; i < n; i++)
        for (k = 0; k < i; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) for (j = 0; j < m; j++) B[i * ld + j] -= f * B[k * ld + j];
        }
    for (i = n - 1; i >= 0; i--) {
        for (k = i + 1; k < n; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) for (j = 0; j < m; j++) B[i * ld + j] -= f * B[k * ld + j];
        }
        for (j = 0; j < m; j++) B[i * ld + j] /= LU[i * n + i];
    }
}

/* ------------------------------------------------------------------------------------ chart */
/* G(xi) V = V + [xi, V]/2 + [xi, [xi, V]]/12 on the free flyer's 6 coordinates. */
static void dexpinv_apply(const double* xi, const double* V, double* out) {
    double r0 = xi[0], r1 = xi[1], r2 = xi[2], p0 = xi[3], p1 = xi[4], p2 = xi[5];
    double v0 = V[0], v1 = V[1], v2 = V[2], w0 = V[3], w1 = V[4], w2 = V[5];
    double a0 = p1 * v2 - p2 * v1 + r1 * w2 - r2 * w1;
    double a1 = p2 * v0 - p0 * v2 + r2 * w0 - r0 * w2;
    double a2 = p0 * v1 - p1 * v0 + r0 * w1 - r1 * w0;
    double a3 = p1 * w2 - p2 * w1;
    double a4 = p2 * w0 - p0 * w2;
    double a5 = p0 * w1 - p1 * w0;
    double b0 = p1 * a2 - p2 * a1 + r1 * a5 - r2 * a4;
    double b1 = p2 * a0 - p0 * a2 + r2 * a3 - r0 * a5;
    double b2 = p0 * a1 - p1 * a0 + r0 * a4 - r1 * a3;
    double b3 = p1 * a5 - p2 * a4;
    double b4 = p2 * a3 - p0 * a5;
    double b5 = p0 * a4 - p1 * a3;
    double c = 1.0 / 12.0;
    out[0] = v0 + 0.5 * a0 + c * b0; out[1] = v1 + 0.5 * a1 + c * b1; out[2] = v2 + 0.5 * a2 + c * b2;
    out[3] = w0 + 0.5 * a3 + c * b3; out[4] = w1 + 0.5 * a4 + c * b4; out[5] = w2 + 0.5 * a5 + c * b5;
}

static void kxi(const double* xi, const double* V, double* out) {
    int i;
    for (i = 0; i < NV; i++) out[i] = V[i];
#if PC_FREE_FLYER
    dexpinv_apply(xi, V, out);
#else
    (void)xi;
#endif
}

#if PC_STEP_JACOBIAN && PC_FREE_FLYER
static void ad6(const double* x, double* A) { /* ad_x (6x6 row-major), x = (linear, angular) */
    double r0 = x[0], r1 = x[1], r2 = x[2], p0 = x[3], p1 = x[4], p2 = x[5];
    double P[9] = {0, -p2, p1, p2, 0, -p0, -p1, p0, 0}, R[9] = {0, -r2, r1, r2, 0, -r0, -r1, r0, 0};
    int i, j;
    memset(A, 0, 36 * sizeof(double));
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            A[i * 6 + j] = P[i * 3 + j];
            A[i * 6 + 3 + j] = R[i * 3 + j];
            A[(3 + i) * 6 + 3 + j] = P[i * 3 + j];
        }
}

static void mat6_mul(const double* A, const double* B, double* C) {
    int i, j, k;
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) {
            double s = 0.0;
            for (k = 0; k < 6; k++) s += A[i * 6 + k] * B[k * 6 + j];
            C[i * 6 + j] = s;
        }
}

/* G = dexpinv(xi) (6x6) and Gx = d(G V)/d xi = -ad_V/2 - (ad_{ad_xi V} + ad_xi ad_V)/12. */
static void dexpinv_mats(const double* xi, const double* V, double* G, double* Gx) {
    double A[36], A2[36], adV[36], adAV[36], AadV[36], AV[6];
    int i, j;
    ad6(xi, A);
    mat6_mul(A, A, A2);
    for (i = 0; i < 36; i++) G[i] = 0.5 * A[i] + A2[i] / 12.0;
    for (i = 0; i < 6; i++) G[i * 6 + i] += 1.0;
    ad6(V, adV);
    for (i = 0; i < 6; i++) {
        AV[i] = 0.0;
        for (j = 0; j < 6; j++) AV[i] += A[i * 6 + j] * V[j];
    }
    ad6(AV, adAV);
    mat6_mul(A, adV, AadV);
    for (i = 0; i < 36; i++) Gx[i] = -0.5 * adV[i] - (adAV[i] + AadV[i]) / 12.0;
}
#endif

/* ------------------------------------------------------------------------------------ Newton */
static int newton_matrix(pc_inst_t* S, const double* q, const double* v, const double* u, double hg) {
    int i;
    if (pc_call_jac(S, q, v, u, S->tmp)) return PC_ERROR;
    for (i = 0; i < NV * NV; i++) S->S[i] = -hg * S->Av[i] - hg * hg * S->Aq[i];
    for (i = 0; i < NV; i++) S->S[i * NV + i] += 1.0;
    if (lu_factor(S->S, S->piv, NV)) {
        pc_logf(S, PC_ERROR, "logStatusError", "singular Newton matrix");
        return PC_ERROR;
    }
    return PC_OK;
}

static int solve_stage(pc_inst_t* S, const double* q, const double* u, const double* xi_bar, const double* V_bar,
                       double hg, double* xi, double* V, double t) {
    double kx[NV], r_xi[NV], rhs[NV], Kv[NV];
    double inv_scale = 1.0, prev = INFINITY;
    int attempt, it, i, j;
    for (i = 0; i < NV; i++) inv_scale += V[i] * V[i] + xi[i] * xi[i];
    inv_scale = 1.0 / inv_scale;
    for (attempt = 0; attempt < 2; attempt++) {
        prev = INFINITY;
        for (it = 0; it < PC_MAX_NEWTON; it++) {
            double err = 0.0;
            if (pc_call_integ(S, q, xi, S->qtmp) || pc_call_ddq(S, S->qtmp, V, u, Kv)) return PC_ERROR;
            kxi(xi, V, kx);
            for (i = 0; i < NV; i++) r_xi[i] = xi[i] - xi_bar[i] - hg * kx[i];
            for (i = 0; i < NV; i++) {
                double s = 0.0;
                for (j = 0; j < NV; j++) s += S->Aq[i * NV + j] * r_xi[j];
                rhs[i] = V_bar[i] - V[i] + hg * (Kv[i] - s);
            }
            lu_solve(S->S, S->piv, NV, rhs, 1, 1);
            for (i = 0; i < NV; i++) {
                double dxi = hg * rhs[i] - r_xi[i];
                xi[i] += dxi;
                V[i] += rhs[i];
                err += rhs[i] * rhs[i] + dxi * dxi;
            }
            err *= inv_scale;
            if (!(err < INFINITY)) break;
            if (err <= PC_NEWTON_TOL2) return PC_OK;
            if (it >= 1) {
                /* error of the iterate ~ rho / (1 - rho) |correction| with the observed contraction rho */
                double rho2 = err / prev;
                if (rho2 < 0.81 && rho2 / ((1.0 - sqrt(rho2)) * (1.0 - sqrt(rho2))) * err <= PC_NEWTON_TOL2) return PC_OK;
                if (it >= 2 && rho2 >= 0.81 && err <= PC_NEWTON_FLOOR2) return PC_OK; /* round-off floor */
            }
            prev = err;
        }
        if (attempt == 0) { /* refresh the matrix at the current stage guess and retry */
            if (pc_call_integ(S, q, xi, S->qtmp2) || newton_matrix(S, S->qtmp2, V, u, hg)) return PC_ERROR;
        }
    }
    pc_logf(S, PC_ERROR, "logStatusError", "Newton did not converge at t = %.17g s (last correction %.3g)", t, sqrt(prev));
    return PC_ERROR;
}

/* ------------------------------------------------------------------------------------ step Jacobian */
#if PC_STEP_JACOBIAN
/* dK (nt x npj) of stage i from its converged point; dZ is solved in place when the stage is implicit. */
static int stage_sensitivity(pc_inst_t* S, int i, const double* q, double h) {
    double G[36], Gx[36], P6[36];
    int piv6[6];
    int r, c, k, j;
    double hg = h * PC_A[i][i];
    double* dZ = S->dZ;
    double* R = S->R;
    if (pc_call_integ(S, q, S->Zxi[i], S->qtmp) || pc_call_jac(S, S->qtmp, S->ZV[i], S->Zu[i], S->tmp)) return PC_ERROR;
    /* dZbar = base + sum_j h a_ij dK_j */
    memset(R, 0, sizeof S->R);
    for (r = 0; r < NV; r++) R[(NV + r) * PC_NPJ + NV + r] = 1.0;
    for (j = 0; j < i; j++)
        if (PC_A[i][j] != 0.0)
            for (k = 0; k < NT * PC_NPJ; k++) R[k] += h * PC_A[i][j] * S->dK[j][k];
#if PC_FREE_FLYER
    dexpinv_mats(S->Zxi[i], S->ZV[i], G, Gx);
#else
    memset(G, 0, sizeof G); memset(Gx, 0, sizeof Gx);
#endif
    if (hg == 0.0) {
        memcpy(dZ, R, sizeof S->dZ);
    } else {
        double* W = S->work;
        /* Rw += hg dKdp_bottom = hg [Aq, 0, dm] */
        for (r = 0; r < NV; r++) {
            for (c = 0; c < NV; c++) R[(NV + r) * PC_NPJ + c] += hg * S->Aq[r * NV + c];
            if (PC_HAS_TARGET) R[(NV + r) * PC_NPJ + NT] += hg * S->dm[r];
        }
        /* W = M^-1 (Rw + hg Aq Rx), M = I - hg Av - hg^2 Aq */
        for (r = 0; r < NV; r++)
            for (c = 0; c < PC_NPJ; c++) {
                double s = R[(NV + r) * PC_NPJ + c];
                for (k = 0; k < NV; k++) s += hg * S->Aq[r * NV + k] * R[k * PC_NPJ + c];
                W[r * PC_NPJ + c] = s;
            }
        for (k = 0; k < NV * NV; k++) S->S[k] = -hg * S->Av[k] - hg * hg * S->Aq[k];
        for (k = 0; k < NV; k++) S->S[k * NV + k] += 1.0;
        if (lu_factor(S->S, S->piv, NV)) return PC_ERROR;
        lu_solve(S->S, S->piv, NV, W, PC_NPJ, PC_NPJ);
        /* X = P (Rx + hg G W): identity on the joints, (I - hg Gx)^-1 on the free flyer */
        for (r = 0; r < NV; r++)
            for (c = 0; c < PC_NPJ; c++) dZ[r * PC_NPJ + c] = R[r * PC_NPJ + c] + hg * W[r * PC_NPJ + c];
#if PC_FREE_FLYER
        for (r = 0; r < 6; r++)
            for (c = 0; c < PC_NPJ; c++) {
                double s = R[r * PC_NPJ + c];
                for (k = 0; k < 6; k++) s += hg * G[r * 6 + k] * W[k * PC_NPJ + c];
                dZ[r * PC_NPJ + c] = s;
            }
        for (k = 0; k < 36; k++) P6[k] = -hg * Gx[k];
        for (k = 0; k < 6; k++) P6[k * 6 + k] += 1.0;
        if (lu_factor(P6, piv6, 6)) return PC_ERROR;
        lu_solve(P6, piv6, 6, dZ, PC_NPJ, PC_NPJ);
#endif
        memcpy(dZ + NV * PC_NPJ, W, NV * PC_NPJ * sizeof(double));
    }
    /* dK = [Gx X + G W ; Aq X + Av W + [Aq, 0, dm]] */
    for (r = 0; r < NV; r++)
        for (c = 0; c < PC_NPJ; c++) {
            double s = (r >= NV - PC_NE || !PC_FREE_FLYER) ? dZ[(NV + r) * PC_NPJ + c] : 0.0;
            double t = 0.0;
#if PC_FREE_FLYER
            if (r < 6)
                for (k = 0; k < 6; k++) s += Gx[r * 6 + k] * dZ[k * PC_NPJ + c] + G[r * 6 + k] * dZ[(NV + k) * PC_NPJ + c];
#endif
            S->dK[i][r * PC_NPJ + c] = s;
            for (k = 0; k < NV; k++) t += S->Aq[r * NV + k] * dZ[k * PC_NPJ + c] + S->Av[r * NV + k] * dZ[(NV + k) * PC_NPJ + c];
            if (c < NV) t += S->Aq[r * NV + c];
            if (PC_HAS_TARGET && c == NT) t += S->dm[r];
            S->dK[i][(NV + r) * PC_NPJ + c] = t;
        }
    return PC_OK;
}

/* Step Jacobian Fs (nt x npj) of the step from q with chart end xi_end. */
static int step_jacobian(pc_inst_t* S, const double* q, const double* xi_end, double h) {
    double* d_end = S->dZ;
    int r, c, k, i;
    if (!PC_STIFFLY_ACCURATE) {
        memset(S->work, 0, sizeof S->work);
        for (r = 0; r < NV; r++) S->work[(NV + r) * PC_NPJ + NV + r] = 1.0;
        for (i = 0; i < PC_STAGES; i++)
            for (k = 0; k < NT * PC_NPJ; k++) S->work[k] += h * PC_B[i] * S->dK[i][k];
        d_end = S->work;
    }
    memcpy(S->Fs, d_end, sizeof S->Fs);
#if PC_FREE_FLYER
    {
        double J0[36], Jr[36];
        S->arg[0] = q; S->arg[1] = xi_end;
        S->res[0] = J0; S->res[1] = Jr;
        if (pc_dint(S->arg, S->res, S->iw, S->w, 0)) return PC_ERROR;
        for (r = 0; r < 6; r++)
            for (c = 0; c < PC_NPJ; c++) {
                double s = 0.0;
                for (k = 0; k < 6; k++) s += CM(Jr, 6, r, k) * d_end[k * PC_NPJ + c];
                S->Fs[r * PC_NPJ + c] = s;
            }
        for (r = 0; r < 6; r++)
            for (c = 0; c < 6; c++) S->Fs[r * PC_NPJ + c] += CM(J0, 6, r, c);
    }
#endif
    for (r = NV - PC_NE; r < NV; r++) S->Fs[r * PC_NPJ + r] += 1.0;
    return PC_OK;
}

static void accumulate(pc_inst_t* S, int first) {
    int r, c, k;
    if (first) {
        memcpy(S->Facc, S->Fs, sizeof S->Facc);
        return;
    }
    for (r = 0; r < NT; r++)
        for (c = 0; c < PC_NPJ; c++) {
            double s = (c == NT) ? S->Fs[r * PC_NPJ + NT] : 0.0;
            for (k = 0; k < NT; k++) s += S->Fs[r * PC_NPJ + k] * S->Facc[k * PC_NPJ + c];
            S->work[r * PC_NPJ + c] = s;
        }
    memcpy(S->Facc, S->work, sizeof S->Facc);
}

static int measurement_jacobian(pc_inst_t* S, double t) {
    double u[PC_NU], ddq[NV], z[PC_NZ], Jzv[PC_NZ * NV], Jza[PC_NZ * NV];
    double* F = S->c.jac;
    double* g = F + NT * NT;
    double* H = g + NT;
    double* hm = H + PC_NZ * NT;
    const double* q = S->c.x;
    const double* v = S->c.x + NQ;
    int r, c, k;
    pc_inputs(S, t, 0, u);
    if (pc_call_jac(S, q, v, u, ddq)) return PC_ERROR;
    S->arg[0] = q; S->arg[1] = v; S->arg[2] = ddq;
    S->res[0] = z; S->res[1] = Jzv; S->res[2] = Jza;
    if (pc_meas(S->arg, S->res, S->iw, S->w, 0)) return PC_ERROR;
    for (r = 0; r < PC_NZ; r++) {
        double sm = 0.0;
        for (c = 0; c < NV; c++) {
            double sq = 0.0, sv = CM(Jzv, PC_NZ, r, c);
            for (k = 0; k < NV; k++) {
                sq += CM(Jza, PC_NZ, r, k) * S->Aq[k * NV + c];
                sv += CM(Jza, PC_NZ, r, k) * S->Av[k * NV + c];
            }
            H[r * NT + c] = sq;
            H[r * NT + NV + c] = sv;
        }
        for (k = 0; k < NV; k++) sm += CM(Jza, PC_NZ, r, k) * S->dm[k];
        hm[r] = sm;
    }
    for (r = 0; r < NT; r++) {
        for (c = 0; c < NT; c++) F[r * NT + c] = S->Facc[r * PC_NPJ + c];
        g[r] = PC_HAS_TARGET ? S->Facc[r * PC_NPJ + NT] : 0.0;
    }
    return PC_OK;
}
#endif

/* ------------------------------------------------------------------------------------ step */
static int substep(pc_inst_t* S, double* q, double* v, double t, double h, int want_jac, int first) {
    double xi_bar[NV], V_bar[NV], xi[NV], V[NV], u0[PC_NU], xi_end[NV], v_end[NV];
    double lu_hg = 0.0;
    int i, j, k;
    for (i = 0; i < PC_STAGES; i++) {
        double g = PC_A[i][i];
        for (k = 0; k < NV; k++) { xi_bar[k] = 0.0; V_bar[k] = v[k]; }
        for (j = 0; j < i; j++)
            if (PC_A[i][j] != 0.0 || j == 0)
                for (k = 0; k < NV; k++) {
                    xi_bar[k] += (h * PC_A[i][j]) * S->Kxi[j][k];
                    V_bar[k] += (h * PC_A[i][j]) * S->Kv[j][k];
                }
        pc_inputs(S, t + PC_C[i] * h, PC_C[i] == 1.0, S->Zu[i]);
        if (g == 0.0) {
            memcpy(xi, xi_bar, sizeof xi);
            memcpy(V, V_bar, sizeof V);
            kxi(xi, V, S->Kxi[i]);
            if (pc_call_integ(S, q, xi, S->qtmp) || pc_call_ddq(S, S->qtmp, V, S->Zu[i], S->Kv[i])) return PC_ERROR;
        } else {
            double hg = h * g, inv = 1.0 / (h * g);
            if (hg != lu_hg) {
                pc_inputs(S, t, 0, u0);
                if (newton_matrix(S, q, v, u0, hg)) return PC_ERROR;
                lu_hg = hg;
            }
            for (k = 0; k < NV; k++) {
                if (i) { xi[k] = xi_bar[k] + hg * S->Kxi[i - 1][k]; V[k] = V_bar[k] + hg * S->Kv[i - 1][k]; }
                else { xi[k] = hg * v[k]; V[k] = v[k]; }
            }
            if (solve_stage(S, q, S->Zu[i], xi_bar, V_bar, hg, xi, V, t)) return PC_ERROR;
            for (k = 0; k < NV; k++) {
                S->Kxi[i][k] = (xi[k] - xi_bar[k]) * inv;
                S->Kv[i][k] = (V[k] - V_bar[k]) * inv;
            }
        }
        memcpy(S->Zxi[i], xi, sizeof xi);
        memcpy(S->ZV[i], V, sizeof V);
    }
#if PC_STEP_JACOBIAN
    /* after every stage is solved: the sensitivities overwrite the Newton matrix */
    if (want_jac)
        for (i = 0; i < PC_STAGES; i++)
            if (stage_sensitivity(S, i, q, h)) return PC_ERROR;
#endif
    if (PC_STIFFLY_ACCURATE) {
        memcpy(xi_end, S->Zxi[PC_STAGES - 1], sizeof xi_end);
        memcpy(v_end, S->ZV[PC_STAGES - 1], sizeof v_end);
    } else {
        for (k = 0; k < NV; k++) { xi_end[k] = 0.0; v_end[k] = 0.0; }
        for (i = 0; i < PC_STAGES; i++)
            for (k = 0; k < NV; k++) { xi_end[k] += PC_B[i] * S->Kxi[i][k]; v_end[k] += PC_B[i] * S->Kv[i][k]; }
        for (k = 0; k < NV; k++) { xi_end[k] *= h; v_end[k] = v[k] + h * v_end[k]; }
    }
#if PC_STEP_JACOBIAN
    if (want_jac) {
        if (step_jacobian(S, q, xi_end, h)) return PC_ERROR;
        accumulate(S, first);
    }
#else
    (void)want_jac; (void)first;
#endif
    if (pc_call_integ(S, q, xi_end, S->qtmp)) return PC_ERROR;
    for (k = 0; k < NQ; k++) if (!(fabs(S->qtmp[k]) < INFINITY)) goto nonfinite;
    for (k = 0; k < NV; k++) if (!(fabs(v_end[k]) < INFINITY)) goto nonfinite;
    memcpy(q, S->qtmp, NQ * sizeof(double));
    memcpy(v, v_end, NV * sizeof(double));
    return PC_OK;
nonfinite:
    pc_logf(S, PC_ERROR, "logStatusError", "non-finite state after the step at t = %.17g s", t);
    return PC_ERROR;
}

int pc_step(pc_inst_t* S, double t, double H, int want_jac) {
    double q[NQ], v[NV];
    int n = (int)floor(H / PC_STEP + 0.5), j;
    double h;
    if (n < 1) n = 1;
    h = fabs(n * PC_STEP - H) <= 1e-9 * H ? PC_STEP : H / n;
    if (!PC_STEP_JACOBIAN) want_jac = 0;
    memcpy(q, S->c.x, sizeof q);
    memcpy(v, S->c.x + NQ, sizeof v);
    for (j = 0; j < n; j++)
        if (substep(S, q, v, t + j * h, h, want_jac, j == 0)) return PC_ERROR;
    memcpy(S->c.x, q, sizeof q);
    memcpy(S->c.x + NQ, v, sizeof v);
    S->c.time = t + H;
    S->out_valid = 0;
    S->c.jac_valid = 0;
#if PC_STEP_JACOBIAN
    if (want_jac) {
        if (measurement_jacobian(S, S->c.time)) return PC_ERROR;
        S->c.jac_valid = 1;
    } else {
        for (j = 0; j < PC_NJAC; j++) S->c.jac[j] = NAN;
    }
#endif
    return PC_OK;
}

