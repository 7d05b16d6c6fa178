/*
 * postcapture engine: the filters' coordinates of the plant's parameters (estimation/parameters.py says which
 * groups). Owns the log-Cholesky map of a body's ten inertial parameters (core/log_cholesky.py: theta in R^10
 * to pi = [m, h, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz] through the pseudo-inertia J = U U^T, always a physical
 * body, Rucker and Wensing 2022) with its exact derivative, and the map of a filter's coordinates eta onto
 * the plant's parameter vector: blocks of ten log-Cholesky coordinates or of logarithms of factors.
 */
#include "pc_filter_internal.h"

/* pi of a pseudo-inertia (I = tr(Sigma) 1 - Sigma on the diagonal and off it) */
static void pi_of(const double J[4][4], double* pi) {
    pi[0] = J[3][3];
    pi[1] = J[0][3];
    pi[2] = J[1][3];
    pi[3] = J[2][3];
    pi[4] = J[1][1] + J[2][2];
    pi[5] = -J[0][1];
    pi[6] = J[0][0] + J[2][2];
    pi[7] = -J[0][2];
    pi[8] = -J[1][2];
    pi[9] = J[0][0] + J[1][1];
}

/* where each off-diagonal coordinate (s12, s23, s13, t1, t2, t3) sits in U */
static const int OFF_R[6] = {0, 1, 0, 0, 1, 2}, OFF_C[6] = {1, 2, 2, 3, 3, 3};

void pc_log_cholesky(const double* th, double* pi, double* dpi) {
    double e = exp(th[0]), U[4][4] = {{0}}, J[4][4], dU[4][4], col[10];
    int i, j, k, c;
    U[0][0] = e * exp(th[1]);
    U[1][1] = e * exp(th[2]);
    U[2][2] = e * exp(th[3]);
    U[3][3] = e;
    U[0][1] = e * th[4];
    U[1][2] = e * th[5];
    U[0][2] = e * th[6];
    U[0][3] = e * th[7];
    U[1][3] = e * th[8];
    U[2][3] = e * th[9];
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            double s = 0.0;
            for (k = 0; k < 4; k++) s += U[i][k] * U[j][k];
            J[i][j] = s;
        }
    if (pi) pi_of((const double(*)[4])J, pi);
    if (!dpi) return;
    for (c = 0; c < 10; c++) {
        memset(dU, 0, sizeof dU);
        if (c == 0) memcpy(dU, U, sizeof dU);
        else if (c <= 3) dU[c - 1][c - 1] = U[c - 1][c - 1];
        else dU[OFF_R[c - 4]][OFF_C[c - 4]] = e;
        for (i = 0; i < 4; i++)
            for (j = 0; j < 4; j++) {
                double s = 0.0;
                for (k = 0; k < 4; k++) s += dU[i][k] * U[j][k] + U[i][k] * dU[j][k];
                J[i][j] = s;
            }
        pi_of((const double(*)[4])J, col);
        for (i = 0; i < 10; i++) dpi[10 * i + c] = col[i];
    }
}

/* the number of coordinates of a spec (-1 when the spec does not fit n_p parameters) */
int pc_parammap_size(const int* spec, int n_spec, int n_p) {
    int b, k, pos = 1, n = 0;
    if (n_spec < 1 || spec[0] < 0) return -1;
    for (b = 0; b < spec[0]; b++) {
        int kind, size;
        if (pos + 2 > n_spec) return -1;
        kind = spec[pos];
        size = spec[pos + 1];
        if ((kind != 0 && kind != 1) || (kind == 0 && size != 10) || size < 1 || pos + 2 + size > n_spec) return -1;
        for (k = 0; k < size; k++)
            if (spec[pos + 2 + k] < 0 || spec[pos + 2 + k] >= n_p) return -1;
        pos += 2 + size;
        n += size;
    }
    return n;
}

void pc_parammap_apply(const int* spec, const double* p_nominal, int n_p, const double* eta, double* p, double* J) {
    int b, k, r, pos = 1, off = 0, n_eta = 0;
    double pi[10], dpi[100];
    for (b = 0, k = 1; b < spec[0]; b++) {
        n_eta += spec[k + 1];
        k += 2 + spec[k + 1];
    }
    if (p) memcpy(p, p_nominal, (size_t)n_p * sizeof(double));
    if (J) memset(J, 0, (size_t)n_p * n_eta * sizeof(double));
    for (b = 0; b < spec[0]; b++) {
        int kind = spec[pos], size = spec[pos + 1];
        const int* index = spec + pos + 2;
        if (kind == 0) {
            pc_log_cholesky(eta + off, pi, J ? dpi : NULL);
            for (r = 0; r < 10; r++) {
                if (p) p[index[r]] = pi[r];
                if (J)
                    for (k = 0; k < 10; k++) J[(size_t)index[r] * n_eta + off + k] = dpi[10 * r + k];
            }
        } else {
            for (k = 0; k < size; k++) {
                double v = exp(eta[off + k]);
                if (p) p[index[k]] = v;
                if (J) J[(size_t)index[k] * n_eta + off + k] = v;
            }
        }
        pos += 2 + size;
        off += size;
    }
}
