/*
 * postcapture plant core: small dense linear algebra. Owns LU with partial pivoting (the dense Newton
 * matrix of coupled springs, the stage sensitivities) and the 6x6 Cholesky factorization of the root's
 * articulated inertia. In place, no allocation.
 */
#include "pc_internal.h"

/* 6x6 symmetric positive definite: Cholesky in place (lower), then solve. */
int pc_chol6(double* A) {
    int i, j, k;
    for (j = 0; j < 6; j++) {
        double s = A[6 * j + j];
        for (k = 0; k < j; k++) s -= A[6 * j + k] * A[6 * j + k];
        if (!(s > 0.0)) return 1;
        A[6 * j + j] = sqrt(s);
        for (i = j + 1; i < 6; i++) {
            double t = A[6 * i + j];
            for (k = 0; k < j; k++) t -= A[6 * i + k] * A[6 * j + k];
            A[6 * i + j] = t / A[6 * j + j];
        }
    }
    return 0;
}

void pc_chol6_solve(const double* L, double* x) {
    int i, k;
    for (i = 0; i < 6; i++) {
        double s = x[i];
        for (k = 0; k < i; k++) s -= L[6 * i + k] * x[k];
        x[i] = s / L[6 * i + i];
    }
    for (i = 5; i >= 0; i--) {
        double s = x[i];
        for (k = i + 1; k < 6; k++) s -= L[6 * k + i] * x[k];
        x[i] = s / L[6 * i + i];
    }
}

int pc_lu_factor(double* A, int* piv, int n) {
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
            if (f != 0.0)
                for (j = k + 1; j < n; j++) A[i * n + j] -= f * A[k * n + j];
        }
    }
    return 0;
}

/* row_i -= f row_k over m entries (distinct rows: restrict lets the compiler vectorize) */
static void axpy_row(double* restrict bi, const double* restrict bk, double f, int m) {
    int j;
    for (j = 0; j < m; j++) bi[j] -= f * bk[j];
}

/* Solve in place for B (n x m, row-major, leading dimension ld). */
void pc_lu_solve(const double* LU, const int* piv, int n, double* B, int m, int ld) {
    int i, j, k;
    for (k = 0; k < n; k++)
        if (piv[k] != k)
            for (j = 0; j < m; j++) { double t = B[k * ld + j]; B[k * ld + j] = B[piv[k] * ld + j]; B[piv[k] * ld + j] = t; }
    for (i = 1; i < n; i++)
        for (k = 0; k < i; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) axpy_row(B + (size_t)i * ld, B + (size_t)k * ld, f, m);
        }
    for (i = n - 1; i >= 0; i--) {
        double inv = 1.0 / LU[i * n + i];
        for (k = i + 1; k < n; k++) {
            double f = LU[i * n + k];
            if (f != 0.0) axpy_row(B + (size_t)i * ld, B + (size_t)k * ld, f, m);
        }
        for (j = 0; j < m; j++) B[i * ld + j] *= inv;
    }
}
