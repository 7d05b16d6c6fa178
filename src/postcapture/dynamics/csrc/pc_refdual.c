/*
 * postcapture engine: the equations of the reference's dual scheme (estimation/dual.py) that sit between its
 * two filters and their plant copy: the state's sensitivity to the mass and what the filters do to it, the
 * mass uncertainty's share of the attitude EKF's process noise, and the devices' prediction over a cycle with
 * its derivative along the sensitivities. The Python scheme and the reference-dual estimator FMU
 * (fmi/csrc/pc_est_refdual.c) call these; neither writes them again. Also the target's mass in the plant's
 * parameter vector (a hub's mass at a fixed centre of mass and inertia about it) and its direction.
 */
#include <stdlib.h>

#include "pc_filter_internal.h"

/* S1 = F S + g (n x n, n, n): the plant state's sensitivity to the mass carried over one step */
void pc_rdual_propagate(int n, const double* F, const double* g, const double* S, double* S1) {
    int i, j;
    for (i = 0; i < n; i++) {
        double s = g[i];
        const double* row = F + (size_t)i * n;
        for (j = 0; j < n; j++) s += row[j] * S[j];
        S1[i] = s;
    }
}

/* the attitude's sensitivity after an accepted star-tracker update of gain K (3 x 3): s <- (I - K) s */
void pc_rdual_lean(const double* K, double* s_att) {
    double s[3];
    int i;
    for (i = 0; i < 3; i++) s[i] = s_att[i] - (K[3 * i] * s_att[0] + K[3 * i + 1] * s_att[1] + K[3 * i + 2] * s_att[2]);
    for (i = 0; i < 3; i++) s_att[i] = s[i];
}

/* what the mass uncertainty does to the plant copy's attitude over a step, as process noise (3 x 3):
 * the rate error is about s_rate (theta_hat - theta), so d = s_rate dt sigma and Q = d d^T */
void pc_rdual_mass_noise(const double* s_rate, double dt, double sigma, double* Q) {
    double d[3];
    int i, j;
    for (i = 0; i < 3; i++) d[i] = s_rate[i] * dt * sigma;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) Q[3 * i + j] = d[i] * d[j];
}

/* The accelerometer's mean specific force over a step and the encoders' angles at its end, predicted from the
 * plant states at the step's two ends (attitudes q0, q1 scalar first; chaser velocities v0, v1 and body rates
 * w0, w1, body components; the arm's angles at the end), and their derivatives along the state's sensitivities
 * at both ends: s0, s1 = the sensitivities' attitude, velocity and rate components (9 each), s1_arm those of
 * the arm's angles at the end (n_arm). z and dz: 3 + n_arm. */
void pc_rdual_devices(const double* q0, const double* q1, const double* v0, const double* w0, const double* v1,
                      const double* w1, const double* r, double dt, const double* s0, const double* s1, int n_arm,
                      const double* angles1, const double* s1_arm, double* z, double* dz) {
    double phi[3], J[54];
    /* J: d f / d att1, att0, v1, w1, v0, w0 (pc_mean_specific_force's order) */
    const double* along[6] = {s1, s0, s1 + 3, s1 + 6, s0 + 3, s0 + 6};
    int i, k;
    pc_q_box_minus(q1, q0, phi);
    pc_mean_specific_force(phi, v0, w0, v1, w1, r, dt, z, J);
    for (i = 0; i < 3; i++) {
        double s = 0.0;
        for (k = 0; k < 6; k++) {
            const double* Jk = J + 9 * k + 3 * i;
            s += Jk[0] * along[k][0] + Jk[1] * along[k][1] + Jk[2] * along[k][2];
        }
        dz[i] = s;
    }
    for (i = 0; i < n_arm; i++) {
        z[3 + i] = angles1[i];
        dz[3 + i] = s1_arm[i];
    }
}

/* d pi / d m of a target's ten inertial parameters (m, m c, inertia about the origin: xx, xy, yy, xz, yz, zz) at
 * a fixed centre of mass c and a fixed inertia about it: [1, c, |c|^2 I - c c^T] */
void pc_dmass_direction(const double* pi, double* d) {
    double c[3] = {pi[1] / pi[0], pi[2] / pi[0], pi[3] / pi[0]}, cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    d[0] = 1.0;
    d[1] = c[0];
    d[2] = c[1];
    d[3] = c[2];
    d[4] = cc - c[0] * c[0];
    d[5] = -c[0] * c[1];
    d[6] = cc - c[1] * c[1];
    d[7] = -c[0] * c[2];
    d[8] = -c[1] * c[2];
    d[9] = cc - c[2] * c[2];
}

/* the ten parameters with the hub's mass set to m at the same centre of mass and inertia about it (the
 * inertia about the origin moves along d pi / d m, which is constant at a fixed centre of mass); PC_ERR_ARG
 * for m <= 0 or a target whose mass is not positive */
int pc_target_mass(const double* pi, double m, double* out) {
    double d[10], m0 = pi[0];
    int i;
    if (!(m > 0.0) || !(m0 > 0.0) || !(fabs(m) < INFINITY)) return PC_ERR_ARG;
    pc_dmass_direction(pi, d);
    for (i = 4; i < 10; i++) out[i] = pi[i] + (m - m0) * d[i]; /* out may be pi */
    for (i = 1; i < 4; i++) out[i] = m * d[i];
    out[0] = m;
    return PC_OK;
}
