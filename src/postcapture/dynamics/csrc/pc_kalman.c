/*
 * postcapture engine: the Kalman kernel every filter uses. Owns the measurement update of a zero error
 * state in Joseph form, with chi-square gating and Schmidt-Kalman consider states, and the linear
 * covariance prediction of the small filters.
 *
 *   S = H P H^T + R,  K = P H^T S^-1 (rows of consider states zeroed),  dx = K nu,
 *   P+ = (I - K H) P (I - K H)^T + K R K^T,  taken as A = P - K (H P), A - (A H^T) K^T + (K R) K^T,
 *
 * every product n x n x m rather than n^3, and S^-1 never formed (Cholesky of S). H is read row by row
 * through its non-zero columns: the filters' measurements read a few states each.
 */
#include "pc_filter_internal.h"

void pc_symmetrize(double* P, int n) {
    int i, j;
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++) {
            double s = 0.5 * (P[(size_t)i * n + j] + P[(size_t)j * n + i]);
            P[(size_t)i * n + j] = P[(size_t)j * n + i] = s;
        }
}

/* P <- sym(Phi P Phi^T + Q), n small; ws: 2 n^2 */
void pc_sym_predict(int n, double* P, const double* Phi, const double* Q, double* ws) {
    int i, j, k;
    double* T = ws;
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++) {
            double s = 0.0;
            for (k = 0; k < n; k++) s += Phi[(size_t)i * n + k] * P[(size_t)k * n + j];
            T[(size_t)i * n + j] = s;
        }
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++) {
            double s = 0.0;
            for (k = 0; k < n; k++) s += T[(size_t)i * n + k] * Phi[(size_t)j * n + k];
            P[(size_t)i * n + j] = s + Q[(size_t)i * n + j];
        }
    pc_symmetrize(P, n);
}

void pc_kf_predict(int n, double* P, const double* F, const double* Q, double* ws) { pc_sym_predict(n, P, F, Q, ws); }

size_t pc_kf_workspace(int n, int m) {
    /* PHt, K, AHt, KR (n x m each), A (n x n), Cholesky factor, the non-zero column lists (as doubles' room) */
    return 4 * (size_t)n * m + (size_t)n * n + (size_t)m * m + (size_t)m * (n + 1) + 8;
}

/* lower Cholesky factor of S (m x m) into L; 0 when positive definite */
static int cholesky(const double* S, double* L, int m) {
    int i, j, k;
    for (i = 0; i < m; i++)
        for (j = 0; j <= i; j++) {
            double s = S[i * m + j];
            for (k = 0; k < j; k++) s -= L[i * m + k] * L[j * m + k];
            if (i == j) {
                if (!(s > 0.0)) return 1;
                L[i * m + i] = sqrt(s);
            } else {
                L[i * m + j] = s / L[j * m + j];
            }
        }
    return 0;
}

/* x <- S^-1 x with S = L L^T */
static void chol_solve(const double* L, int m, double* x) {
    int i, k;
    for (i = 0; i < m; i++) {
        double s = x[i];
        for (k = 0; k < i; k++) s -= L[i * m + k] * x[k];
        x[i] = s / L[i * m + i];
    }
    for (i = m - 1; i >= 0; i--) {
        double s = x[i];
        for (k = i + 1; k < m; k++) s -= L[k * m + i] * x[k];
        x[i] = s / L[i * m + i];
    }
}

/* innovation covariance S and the Cholesky factor; PHt (n x m) from the rows' non-zero columns */
static int innovation_covariance(int n, int m, const double* P, const double* H, const double* R, const int* nz,
                                 const int* n_nz, double* PHt, pc_update_t* res, double* L) {
    int i, a, b, k;
    double* S = res->S;
    for (i = 0; i < n; i++)
        for (a = 0; a < m; a++) {
            double s = 0.0;
            const int* cols = nz + (size_t)a * n;
            for (k = 0; k < n_nz[a]; k++) s += P[(size_t)i * n + cols[k]] * H[(size_t)a * n + cols[k]];
            PHt[(size_t)i * m + a] = s;
        }
    for (a = 0; a < m; a++)
        for (b = 0; b < m; b++) {
            double s = 0.0;
            const int* cols = nz + (size_t)a * n;
            for (k = 0; k < n_nz[a]; k++) s += H[(size_t)a * n + cols[k]] * PHt[(size_t)cols[k] * m + b];
            S[a * m + b] = s + R[a * m + b];
        }
    pc_symmetrize(S, m);
    for (a = 0; a < m * m; a++)
        if (!(fabs(S[a]) < INFINITY)) return PC_ERR_NONFINITE;
    return cholesky(S, L, m) ? PC_ERR_SINGULAR : PC_OK;
}

/* P <- sym(A - (A H^T) K^T + (K R) K^T) with A = P - K (H P) */
static void joseph(int n, int m, double* P, const double* H, const double* R, const int* nz, const int* n_nz,
                   const double* PHt, const double* K, double* A, double* AHt, double* KR) {
    int i, j, a, b, k;
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++) {
            double s = 0.0;
            for (a = 0; a < m; a++) s += K[(size_t)i * m + a] * PHt[(size_t)j * m + a];
            A[(size_t)i * n + j] = P[(size_t)i * n + j] - s;
        }
    for (i = 0; i < n; i++)
        for (a = 0; a < m; a++) {
            double s = 0.0, r = 0.0;
            const int* cols = nz + (size_t)a * n;
            for (k = 0; k < n_nz[a]; k++) s += A[(size_t)i * n + cols[k]] * H[(size_t)a * n + cols[k]];
            AHt[(size_t)i * m + a] = s;
            for (b = 0; b < m; b++) r += K[(size_t)i * m + b] * R[b * m + a];
            KR[(size_t)i * m + a] = r;
        }
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++) {
            double s = 0.0, r = 0.0;
            for (a = 0; a < m; a++) {
                s += AHt[(size_t)i * m + a] * K[(size_t)j * m + a];
                r += KR[(size_t)i * m + a] * K[(size_t)j * m + a];
            }
            A[(size_t)i * n + j] = (A[(size_t)i * n + j] - s) + r;
        }
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++) P[(size_t)i * n + j] = 0.5 * (A[(size_t)i * n + j] + A[(size_t)j * n + i]);
}

int pc_kf_update(int n, int m, double* P, const double* nu, const double* H, const double* R,
                 const unsigned char* consider, double threshold, double* dx, double* K_out, pc_update_t* res,
                 double* ws) {
    int i, a, err;
    double *PHt = ws, *K = PHt + (size_t)n * m, *AHt = K + (size_t)n * m, *KR = AHt + (size_t)n * m;
    double *A = KR + (size_t)n * m, *L = A + (size_t)n * n, y[PC_MAX_MEAS];
    int* nz = (int*)(L + (size_t)m * m);
    int n_nz[PC_MAX_MEAS];
    if (m < 1 || m > PC_MAX_MEAS) return PC_ERR_ARG;
    res->m = m;
    res->missing = 0;
    res->accepted = 0;
    res->threshold = threshold;
    for (a = 0; a < m; a++) {
        res->innovation[a] = nu[a];
        n_nz[a] = 0;
        for (i = 0; i < n; i++)
            if (H[(size_t)a * n + i] != 0.0) nz[(size_t)a * n + n_nz[a]++] = i;
    }
    err = innovation_covariance(n, m, P, H, R, nz, n_nz, PHt, res, L);
    if (err) return err;
    for (a = 0; a < m; a++) y[a] = nu[a];
    chol_solve(L, m, y);
    res->nis = 0.0;
    for (a = 0; a < m; a++) res->nis += nu[a] * y[a];
    for (i = 0; i < n; i++) {
        double* Ki = K + (size_t)i * m;
        if (consider && consider[i]) {
            for (a = 0; a < m; a++) Ki[a] = 0.0;
            continue;
        }
        for (a = 0; a < m; a++) Ki[a] = PHt[(size_t)i * m + a];
        chol_solve(L, m, Ki);
    }
    if (K_out) memcpy(K_out, K, (size_t)n * m * sizeof(double));
    if (threshold >= 0.0 && !(res->nis <= threshold)) return PC_OK;
    res->accepted = 1;
    joseph(n, m, P, H, R, nz, n_nz, PHt, K, A, AHt, KR);
    if (dx)
        for (i = 0; i < n; i++) {
            double s = 0.0;
            for (a = 0; a < m; a++) s += K[(size_t)i * m + a] * nu[a];
            dx[i] = s;
        }
    return PC_OK;
}

/* a filter's update: its gate, the kernel, and a divergence when S is not a covariance (P then unchanged) */
int pc_kf_run(pc_book_t* b, int kind, double t, int n, int m, double* P, const double* nu, const double* H,
              const double* R, const unsigned char* consider, double* dx, double* K, pc_update_t* res, double* ws) {
    int err = pc_kf_update(n, m, P, nu, H, R, consider, pc_book_gate(b, kind, m), dx, K, res, ws);
    if (err == PC_ERR_ARG) return err;
    if (err) {
        pc_book_diverge(b, t, err == PC_ERR_NONFINITE ? PC_CAUSE_S_NONFINITE : PC_CAUSE_S_NOT_PD, kind, NULL);
        res->missing = 1;
    }
    return err;
}
