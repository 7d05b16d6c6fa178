/*
 * postcapture engine: the filters' attitude maps on scalar-first unit quaternions (w, x, y, z), right
 * (body-frame) perturbations, the package's conventions (core/rotations.py): normalisation with w >= 0,
 * box-plus q (+) d = q (x) Exp(d), box-minus, the rotation matrix Exp(phi) and the inverse right Jacobian
 * of SO(3). The plant's configuration group (x y z w storage) is pc_liegroup.c's.
 */
#include "pc_filter_internal.h"

void pc_q_normalize(double* q) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int i;
    for (i = 0; i < 4; i++) q[i] /= n;
    if (q[0] < 0.0)
        for (i = 0; i < 4; i++) q[i] = -q[i];
}

/* raw Hamilton product p (x) q, scalar first */
static void hamilton(const double* p, const double* q, double* out) {
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3];
    out[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2];
    out[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1];
    out[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0];
}

void pc_q_box_plus(const double* q, const double* d, double* out) {
    double a = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), half = 0.5 * a, k, e[4];
    k = a < 1e-4 ? 0.5 - a * a / 48.0 : sin(half) / a;
    e[0] = cos(half);
    e[1] = k * d[0];
    e[2] = k * d[1];
    e[3] = k * d[2];
    hamilton(q, e, out);
    pc_q_normalize(out);
}

/* d with q2 (+) d = q1 */
void pc_q_box_minus(const double* q1, const double* q2, double* d) {
    double c[4] = {q2[0], -q2[1], -q2[2], -q2[3]}, r[4], s, angle, k;
    hamilton(c, q1, r);
    pc_q_normalize(r);
    s = sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    angle = 2.0 * atan2(s, r[0]);
    k = s < 1e-8 ? 2.0 / (r[0] > 1e-300 ? r[0] : 1e-300) : angle / s;
    d[0] = k * r[1];
    d[1] = k * r[2];
    d[2] = k * r[3];
}

void pc_q_from_xyzw(const double* xyzw, double* q) {
    q[0] = xyzw[3];
    q[1] = xyzw[0];
    q[2] = xyzw[1];
    q[3] = xyzw[2];
    pc_q_normalize(q);
}

void pc_skew(const double* v, double* S) {
    S[0] = 0.0; S[1] = -v[2]; S[2] = v[1];
    S[3] = v[2]; S[4] = 0.0; S[5] = -v[0];
    S[6] = -v[1]; S[7] = v[0]; S[8] = 0.0;
}

void pc_mm3(const double* A, const double* B, double* C) {
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* I + a W + b W^2 */
static void poly_skew(const double* phi, double a, double b, double* out) {
    double W[9], W2[9];
    int i;
    pc_skew(phi, W);
    pc_mm3(W, W, W2);
    for (i = 0; i < 9; i++) out[i] = (i % 4 == 0 ? 1.0 : 0.0) + a * W[i] + b * W2[i];
}

void pc_exp_matrix(const double* phi, double* E) {
    double th = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    if (th < 1e-6)
        poly_skew(phi, 1.0, 0.5, E);
    else
        poly_skew(phi, sin(th) / th, (1.0 - cos(th)) / (th * th), E);
}

/* log(Exp(phi) Exp(a)) = phi + Jr^-1(phi) a to first order; Jl^-1(phi) = Jr^-1(-phi) */
void pc_jr_inv(const double* phi, double* J) {
    double th = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]), c;
    if (th < 1e-4)
        c = 1.0 / 12.0 + th * th / 720.0;
    else
        c = 1.0 / (th * th) - (1.0 + cos(th)) / (2.0 * th * sin(th));
    poly_skew(phi, 0.5, c, J);
}
