/*
 * postcapture engine: what the chaser's inertial sensors output over one filter cycle, as exact functions of
 * the states at its two ends (estimation/increments.py explains them), with their Jacobians:
 *   - the gyro's mean rate box_minus(q1, q0) / dt;
 *   - the accelerometer's mean specific force (Exp(phi) u1 - u0) / dt, u = v + w x r its point's velocity
 *     less, when the filters model the orbit, the tidal acceleration's mean over the cycle (pc_tidal_mean);
 * and the calibration of a sensor triad, C = I + diag(s) + M (core/triad.py: c = (s, the six off-diagonal
 * terms of M, row-major)) with d (C w) / d c.
 */
#include "pc_filter_internal.h"

static const int OFF[6][2] = {{0, 1}, {0, 2}, {1, 0}, {1, 2}, {2, 0}, {2, 1}};

/* z = phi / dt, H1 = Jr^-1(phi) / dt (attitude error at the end), H0 = -Jl^-1(phi) / dt (at the start) */
void pc_mean_rate(const double* q0, const double* q1, double dt, double* z, double* H1, double* H0, double* phi) {
    double p[3], mp[3];
    int i;
    pc_q_box_minus(q1, q0, p);
    for (i = 0; i < 3; i++) {
        z[i] = p[i] / dt;
        mp[i] = -p[i];
        if (phi) phi[i] = p[i];
    }
    if (H1) {
        pc_jr_inv(p, H1);
        for (i = 0; i < 9; i++) H1[i] /= dt;
    }
    if (H0) {
        pc_jr_inv(mp, H0);
        for (i = 0; i < 9; i++) H0[i] = -H0[i] / dt;
    }
}

/* J: att1, att0, v1, w1, v0, w0 (3 x 3 each) */
void pc_mean_specific_force(const double* phi, const double* v0, const double* w0, const double* v1,
                            const double* w1, const double* r, double dt, double* z, double* J) {
    double E[9], R[9], u0[3], u1[3], Eu1[3], S[9], T[9];
    int i, j;
    pc_exp_matrix(phi, E);
    pc_skew(r, R);
    for (i = 0; i < 3; i++) {
        u0[i] = v0[i] - (R[3 * i] * w0[0] + R[3 * i + 1] * w0[1] + R[3 * i + 2] * w0[2]);
        u1[i] = v1[i] - (R[3 * i] * w1[0] + R[3 * i + 1] * w1[1] + R[3 * i + 2] * w1[2]);
    }
    for (i = 0; i < 3; i++) Eu1[i] = E[3 * i] * u1[0] + E[3 * i + 1] * u1[1] + E[3 * i + 2] * u1[2];
    for (i = 0; i < 3; i++) z[i] = (Eu1[i] - u0[i]) / dt;
    if (!J) return;
    pc_skew(u1, S);
    pc_mm3(E, S, T);
    for (i = 0; i < 9; i++) J[i] = -T[i] / dt;          /* att1 */
    pc_skew(Eu1, S);
    for (i = 0; i < 9; i++) J[9 + i] = S[i] / dt;       /* att0 */
    for (i = 0; i < 9; i++) J[18 + i] = E[i] / dt;      /* v1 */
    pc_mm3(E, R, T);
    for (i = 0; i < 9; i++) J[27 + i] = -T[i] / dt;     /* w1 */
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) J[36 + 3 * i + j] = (i == j ? -1.0 : 0.0) / dt; /* v0 */
    for (i = 0; i < 9; i++) J[45 + i] = R[i] / dt;      /* w0 */
}

void pc_triad_matrix(const double* c, double* C) {
    int i;
    for (i = 0; i < 9; i++) C[i] = 0.0;
    for (i = 0; i < 6; i++) C[3 * OFF[i][0] + OFF[i][1]] = c[3 + i];
    for (i = 0; i < 3; i++) C[4 * i] = 1.0 + c[i] + C[4 * i];
}

/* D (3 x 9) = d (C w) / d c */
void pc_triad_sensitivity(const double* w, double* D) {
    int i;
    for (i = 0; i < 27; i++) D[i] = 0.0;
    for (i = 0; i < 3; i++) D[9 * i + i] = w[i];
    for (i = 0; i < 6; i++) D[9 * OFF[i][0] + 3 + i] = w[OFF[i][1]];
}

/* active rotation R_NB of a scalar-first q_BN (normalised): C_BN = R^T */
static void rotation(const double* q_in, double* R) {
    double n = sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
    double w = q_in[0] / n, x = q_in[1] / n, y = q_in[2] / n, z = q_in[3] / n;
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - w * z); R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z); R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y); R[7] = 2 * (y * z + w * x); R[8] = 1 - 2 * (x * x + y * y);
}

/* The orbit's tidal acceleration g(x, t) = n^2 (3 (z . x) z - x), z = (cos n t, sin n t, 0) the zenith in N, at
 * the point r + C_NB r_B of B at both ends of a cycle, averaged (trapezoid) and put in the body frame at its start. */
void pc_tidal_mean(const double* q0, const double* r0, const double* q1, const double* r1, const double* rB,
                   double n, double t0, double t1, double* out) {
    const double* qs[2] = {q0, q1};
    const double* rs[2] = {r0, r1};
    double ts[2] = {t0, t1}, total[3] = {0, 0, 0}, R[9], n2 = n * n, half[3];
    int e, i;
    for (i = 0; i < 3; i++) out[i] = 0.0;
    if (n == 0.0) return;
    for (e = 0; e < 2; e++) {
        double p[3], z[3] = {cos(n * ts[e]), sin(n * ts[e]), 0.0}, zp;
        rotation(qs[e], R);
        for (i = 0; i < 3; i++) p[i] = rs[e][i] + (R[3 * i] * rB[0] + R[3 * i + 1] * rB[1] + R[3 * i + 2] * rB[2]);
        zp = z[0] * p[0] + z[1] * p[1] + z[2] * p[2];
        for (i = 0; i < 3; i++) total[i] += n2 * (3.0 * z[i] * zp - p[i]);
    }
    rotation(q0, R);
    for (i = 0; i < 3; i++) half[i] = 0.5 * total[i];
    for (i = 0; i < 3; i++) out[i] = R[i] * half[0] + R[3 + i] * half[1] + R[6 + i] * half[2];
}
