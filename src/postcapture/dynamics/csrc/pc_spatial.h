/*
 * postcapture plant core: the 3-D and 6-D spatial algebra every stage uses (inline, no state).
 * Owns: cross products, placements acting on motions and forces, spatial inertias times twists, the
 * single-axis rotations of revolute joints and the quaternion-to-matrix map (Eigen's formula).
 */
#ifndef PC_SPATIAL_H
#define PC_SPATIAL_H

#include <math.h>
#include <string.h>

/* ---------------------------------------------------------------------------------- 3-D and 6-D algebra */
static inline void cross3(const double* a, const double* b, double* out) {
    double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    out[0] = x; out[1] = y; out[2] = z;
}

static inline void mv3(const double* R, const double* x, double* out) { /* R x */
    double a = R[0] * x[0] + R[1] * x[1] + R[2] * x[2];
    double b = R[3] * x[0] + R[4] * x[1] + R[5] * x[2];
    double c = R[6] * x[0] + R[7] * x[1] + R[8] * x[2];
    out[0] = a; out[1] = b; out[2] = c;
}

static inline void mtv3(const double* R, const double* x, double* out) { /* R^T x */
    double a = R[0] * x[0] + R[3] * x[1] + R[6] * x[2];
    double b = R[1] * x[0] + R[4] * x[1] + R[7] * x[2];
    double c = R[2] * x[0] + R[5] * x[1] + R[8] * x[2];
    out[0] = a; out[1] = b; out[2] = c;
}

static inline void mm3(const double* A, const double* B, double* C) { /* C = A B (C may not alias) */
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* motion in the parent frame -> child frame placed at (R, p): (R^T (v - p x w), R^T w) */
static inline void motion_act_inv(const double* R, const double* p, const double* m, double* out) {
    double t[3], pw[3];
    cross3(p, m + 3, pw);
    t[0] = m[0] - pw[0]; t[1] = m[1] - pw[1]; t[2] = m[2] - pw[2];
    mtv3(R, m + 3, out + 3);
    mtv3(R, t, out);
}

/* motion in the child frame -> parent frame: (R v + p x R w, R w) */
static inline void motion_act(const double* R, const double* p, const double* m, double* out) {
    double w[3], v[3], pw[3];
    mv3(R, m + 3, w);
    mv3(R, m, v);
    cross3(p, w, pw);
    out[0] = v[0] + pw[0]; out[1] = v[1] + pw[1]; out[2] = v[2] + pw[2];
    out[3] = w[0]; out[4] = w[1]; out[5] = w[2];
}

/* wrench in the child frame -> parent frame: (R f, R n + p x R f) */
static inline void force_act(const double* R, const double* p, const double* f, double* out) {
    double fl[3], n[3], pf[3];
    mv3(R, f, fl);
    mv3(R, f + 3, n);
    cross3(p, fl, pf);
    out[0] = fl[0]; out[1] = fl[1]; out[2] = fl[2];
    out[3] = n[0] + pf[0]; out[4] = n[1] + pf[1]; out[5] = n[2] + pf[2];
}

/* twist cross twist: v x m = (w x m_l + v_l x m_w, w x m_w) */
static inline void cross_motion(const double* v, const double* m, double* out) {
    double a[3], b[3], c[3];
    cross3(v + 3, m, a);
    cross3(v, m + 3, b);
    cross3(v + 3, m + 3, c);
    out[0] = a[0] + b[0]; out[1] = a[1] + b[1]; out[2] = a[2] + b[2];
    out[3] = c[0]; out[4] = c[1]; out[5] = c[2];
}

/* twist cross wrench: v x* f = (w x f_l, w x f_n + v_l x f_l) */
static inline void cross_force(const double* v, const double* f, double* out) {
    double a[3], b[3], c[3];
    cross3(v + 3, f, a);
    cross3(v + 3, f + 3, b);
    cross3(v, f, c);
    out[0] = a[0]; out[1] = a[1]; out[2] = a[2];
    out[3] = b[0] + c[0]; out[4] = b[1] + c[1]; out[5] = b[2] + c[2];
}

/* the matrix X of v x . on twists (ad_v): X = [[w]x, [vl]x; 0, [w]x] */
static inline void motion_cross_matrix(const double* v, double* X) {
    const double W[9] = {0, -v[5], v[4], v[5], 0, -v[3], -v[4], v[3], 0};
    const double L[9] = {0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0};
    int i, j;
    memset(X, 0, 36 * sizeof(double));
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            X[6 * i + j] = W[3 * i + j];
            X[6 * i + 3 + j] = L[3 * i + j];
            X[6 * (3 + i) + 3 + j] = W[3 * i + j];
        }
}

/* spatial inertia (dynamic parameters) times a twist: (m v - h x w, I_O w + h x v) */
static inline void inertia_mul(const double* pi, const double* v, double* out) {
    double m = pi[0];
    const double* h = pi + 1;
    double hw[3], hv[3];
    cross3(h, v + 3, hw);
    cross3(h, v, hv);
    out[0] = m * v[0] - hw[0]; out[1] = m * v[1] - hw[1]; out[2] = m * v[2] - hw[2];
    out[3] = pi[4] * v[3] + pi[5] * v[4] + pi[7] * v[5] + hv[0];
    out[4] = pi[5] * v[3] + pi[6] * v[4] + pi[8] * v[5] + hv[1];
    out[5] = pi[7] * v[3] + pi[8] * v[4] + pi[9] * v[5] + hv[2];
}

static inline void mv6(const double* A, const double* x, double* out) {
    int i;
    for (i = 0; i < 6; i++)
        out[i] = A[6 * i] * x[0] + A[6 * i + 1] * x[1] + A[6 * i + 2] * x[2] + A[6 * i + 3] * x[3] +
                 A[6 * i + 4] * x[4] + A[6 * i + 5] * x[5];
}

static inline double dot6(const double* a, const double* b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5];
}

/* The same transforms for a joint whose placement is a rotation about axis k (cosine c, sine s) and a
 * translation p: R x and R^T x cost 4 products instead of 9. */
static const int PC_NEXT1[3] = {1, 2, 0}, PC_NEXT2[3] = {2, 0, 1};

static inline void rot_axis_apply(int k, double c, double s, const double* x, double* o) {
    int i = PC_NEXT1[k], j = PC_NEXT2[k];
    double xi = x[i], xj = x[j];
    o[k] = x[k]; o[i] = c * xi - s * xj; o[j] = s * xi + c * xj;
}

static inline void rot_axis_apply_t(int k, double c, double s, const double* x, double* o) {
    int i = PC_NEXT1[k], j = PC_NEXT2[k];
    double xi = x[i], xj = x[j];
    o[k] = x[k]; o[i] = c * xi + s * xj; o[j] = -s * xi + c * xj;
}

static inline void motion_act_inv_axis(int k, double c, double s, const double* p, const double* m, double* out) {
    double t[3], pw[3];
    cross3(p, m + 3, pw);
    t[0] = m[0] - pw[0]; t[1] = m[1] - pw[1]; t[2] = m[2] - pw[2];
    rot_axis_apply_t(k, c, s, m + 3, out + 3);
    rot_axis_apply_t(k, c, s, t, out);
}

static inline void force_act_axis(int k, double c, double s, const double* p, const double* f, double* out) {
    double fl[3], n[3], pf[3];
    rot_axis_apply(k, c, s, f, fl);
    rot_axis_apply(k, c, s, f + 3, n);
    cross3(p, fl, pf);
    out[0] = fl[0]; out[1] = fl[1]; out[2] = fl[2];
    out[3] = n[0] + pf[0]; out[4] = n[1] + pf[1]; out[5] = n[2] + pf[2];
}

/* Joint i's placement acting on a motion (parent -> child) or a force (child -> parent), with the
 * placements R (9 per joint), p (3) and cos/sin cs (2) of a configuration. */
#define PC_MOTION_INV(m_, R_, p_, cs_, i_, in_, out_)                                                     \
    ((m_)->joints[i_].axis_only                                                                         \
         ? motion_act_inv_axis((m_)->joints[i_].kind, (cs_)[2 * (i_)], (cs_)[2 * (i_) + 1], (p_) + 3 * (i_), in_, out_) \
         : motion_act_inv((R_) + 9 * (i_), (p_) + 3 * (i_), in_, out_))
#define PC_FORCE_ACT(m_, R_, p_, cs_, i_, in_, out_)                                                      \
    ((m_)->joints[i_].axis_only                                                                         \
         ? force_act_axis((m_)->joints[i_].kind, (cs_)[2 * (i_)], (cs_)[2 * (i_) + 1], (p_) + 3 * (i_), in_, out_) \
         : force_act((R_) + 9 * (i_), (p_) + 3 * (i_), in_, out_))

/* Rotation of the joint about its axis by angle q (kind 0/1/2 = x/y/z), row-major. */
static inline void axis_rotation(int kind, double q, double* R) {
    double c = cos(q), s = sin(q);
    int i = (kind + 1) % 3, j = (kind + 2) % 3;
    memset(R, 0, 9 * sizeof(double));
    R[4 * kind] = 1.0;
    R[3 * i + i] = c; R[3 * i + j] = -s;
    R[3 * j + i] = s; R[3 * j + j] = c;
}

/* quaternion (x, y, z, w) -> rotation matrix, Eigen's formula */
static inline void quat_to_matrix(const double* q, double* R) {
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double tx = 2 * x, ty = 2 * y, tz = 2 * z;
    double twx = tx * w, twy = ty * w, twz = tz * w, txx = tx * x, txy = ty * x, txz = tz * x;
    double tyy = ty * y, tyz = tz * y, tzz = tz * z;
    R[0] = 1 - (tyy + tzz); R[1] = txy - twz; R[2] = txz + twy;
    R[3] = txy + twz; R[4] = 1 - (txx + tzz); R[5] = tyz - twx;
    R[6] = txz - twy; R[7] = tyz + twx; R[8] = 1 - (txx + tyy);
}

#endif
