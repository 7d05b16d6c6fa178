/*
 * postcapture plant core: the configuration group. Owns box-plus and box-minus (q1 = q (+) dq and
 * dq = q1 (-) q0: the SE(3) exponential and logarithm on a free-flyer root, stored as position and
 * quaternion x y z w, with right perturbations of its body twist (linear, angular); addition on the
 * joint angles), the tangent maps of q (+) xi on SE(3) and the inverse differential of the exponential
 * that the Munthe-Kaas stages carry their velocities through. These are the only implementation of
 * box-plus and box-minus in postcapture (the Python side calls them).
 */
#include "pc_internal.h"

/* series or closed form of sin(t/2)/t, cos(t/2) and (t - sin t)/t^3 at t^2 */
static void exp_coefficients(double t2, double* sh, double* ch, double* cc) {
    if (t2 < 1e-2) {
        *sh = 0.5 + t2 * (-1.0 / 48 + t2 * (1.0 / 3840 + t2 * (-1.0 / 645120 + t2 * (1.0 / 185794560))));
        *ch = 1.0 + t2 * (-1.0 / 8 + t2 * (1.0 / 384 + t2 * (-1.0 / 46080 + t2 * (1.0 / 10321920))));
        *cc = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880 + t2 * (1.0 / 39916800))));
    } else {
        double t = sqrt(t2);
        *sh = sin(0.5 * t) / t;
        *ch = cos(0.5 * t);
        *cc = (t - sin(t)) / (t2 * t);
    }
}

/* Hamilton product of quaternions stored (x, y, z, w) */
static void quat_mul(const double* a, const double* e, double* out) {
    out[0] = a[3] * e[0] + a[0] * e[3] + a[1] * e[2] - a[2] * e[1];
    out[1] = a[3] * e[1] - a[0] * e[2] + a[1] * e[3] + a[2] * e[0];
    out[2] = a[3] * e[2] + a[0] * e[1] - a[1] * e[0] + a[2] * e[3];
    out[3] = a[3] * e[3] - a[0] * e[0] - a[1] * e[1] - a[2] * e[2];
}

/* the free flyer's (position, quaternion) times exp(dq), dq = (v, w) in the body frame */
static void se3_integrate(const double* q, const double* dq, double* q1) {
    const double* v = dq;
    const double* w = dq + 3;
    double t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], sh, ch, cc, bc, wxv[3], wwv[3], Vv[3], R0[9], d[3];
    double e[4], qn[4], dotq, n2, s;
    int i;
    exp_coefficients(t2, &sh, &ch, &cc);
    bc = 2.0 * sh * sh;
    cross3(w, v, wxv);
    cross3(w, wxv, wwv);
    for (i = 0; i < 3; i++) Vv[i] = v[i] + bc * wxv[i] + cc * wwv[i];
    quat_to_matrix(q + 3, R0);
    mv3(R0, Vv, d);
    for (i = 0; i < 3; i++) q1[i] = q[i] + d[i];
    e[0] = sh * w[0]; e[1] = sh * w[1]; e[2] = sh * w[2]; e[3] = ch;
    quat_mul(q + 3, e, qn);
    dotq = qn[0] * q[3] + qn[1] * q[4] + qn[2] * q[5] + qn[3] * q[6];
    if (dotq < 0) for (i = 0; i < 4; i++) qn[i] = -qn[i];
    n2 = qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3];
    s = (3.0 - n2) / 2.0;
    for (i = 0; i < 4; i++) q1[3 + i] = qn[i] * s;
}

/* dq = log(T0^-1 T1) for the free flyer: w from the relative quaternion, v = V(w)^-1 R0^T (p1 - p0) */
static void se3_difference(const double* q0, const double* q1, double* dq) {
    double c0[4] = {-q0[3], -q0[4], -q0[5], q0[6]}, r[4], R0[9], dp[3], pl[3], w[3], wp[3], wwp[3];
    double s, t, t2, k, g;
    int i;
    quat_mul(c0, q1 + 3, r);
    if (r[3] < 0) for (i = 0; i < 4; i++) r[i] = -r[i];
    s = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    t = 2.0 * atan2(s, r[3]);
    k = s > 1e-12 ? t / s : 2.0 / r[3]; /* theta / sin(theta / 2) */
    for (i = 0; i < 3; i++) w[i] = k * r[i];
    quat_to_matrix(q0 + 3, R0);
    for (i = 0; i < 3; i++) dp[i] = q1[i] - q0[i];
    mtv3(R0, dp, pl);
    t2 = t * t;
    /* V^-1 = I - W/2 + g W^2, g = (1 - t sin t / (2 (1 - cos t))) / t^2 */
    if (t2 < 1e-4) g = 1.0 / 12 + t2 * (1.0 / 720 + t2 / 30240);
    else g = (1.0 - t * sin(t) / (2.0 * (1.0 - cos(t)))) / t2;
    cross3(w, pl, wp);
    cross3(w, wp, wwp);
    for (i = 0; i < 3; i++) {
        dq[i] = pl[i] - 0.5 * wp[i] + g * wwp[i];
        dq[3 + i] = w[i];
    }
}

int pc_lie_integrate(int nq, int nv, int free_flyer, const double* q, const double* dq, double* q1) {
    int i, off = nq - nv, r = free_flyer ? 6 : 0;
    if (nq < 0 || nv < 0 || off != (free_flyer ? 1 : 0) || nv < r) return PC_ERR_ARG;
    if (free_flyer) se3_integrate(q, dq, q1);
    for (i = r; i < nv; i++) q1[i + off] = q[i + off] + dq[i];
    return PC_OK;
}

int pc_lie_difference(int nq, int nv, int free_flyer, const double* q0, const double* q1, double* dq) {
    int i, off = nq - nv, r = free_flyer ? 6 : 0;
    if (nq < 0 || nv < 0 || off != (free_flyer ? 1 : 0) || nv < r) return PC_ERR_ARG;
    if (free_flyer) se3_difference(q0, q1, dq);
    for (i = r; i < nv; i++) dq[i] = q1[i + off] - q0[i + off];
    return PC_OK;
}

int pc_integrate(const pc_model_t* m, const double* q, const double* dq, double* q1) {
    return pc_lie_integrate(m->nq, m->nv, m->free_flyer, q, dq, q1);
}

int pc_difference(const pc_model_t* m, const double* q0, const double* q1, double* dq) {
    return pc_lie_difference(m->nq, m->nv, m->free_flyer, q0, q1, dq);
}

static void skew3(const double* a, double* S) {
    S[0] = 0; S[1] = -a[2]; S[2] = a[1]; S[3] = a[2]; S[4] = 0; S[5] = -a[0]; S[6] = -a[1]; S[7] = a[0]; S[8] = 0;
}

/* Tangent maps of q1 = q0 exp(xi) on SE(3): J0 = d q1 / d q0 = Ad(exp(xi)^-1), Jr = d q1 / d xi (right
 * Jacobian of the exponential), both 6x6 for right perturbations (Pinocchio's dIntegrate). */
void pc_dintegrate_root(const double* xi, double* J0, double* Jr) {
    const double* v = xi;
    const double* w = xi + 3;
    double t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    double a, b, c2, c3, c4, W[9], V[9], W2[9], Re[9], pe[3], Vm[9], J3[9], Q[9];
    double WV[9], VW[9], WVW[9], WWV[9], VWW[9], WVWW[9], WWVW[9], tmp[9], RtP[9], P[9];
    int i, j;
    if (t2 < 1e-2) {
        a = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320)));  /* (1 - cos t)/t^2 */
        b = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880))); /* (t - sin t)/t^3 */
        c3 = 1.0 / 24 + t2 * (-1.0 / 720 + t2 * (1.0 / 40320 + t2 * (-1.0 / 3628800)));
        c4 = 1.0 / 120 + t2 * (-1.0 / 2520 + t2 * (1.0 / 120960));
    } else {
        double t = sqrt(t2), s = sin(t), co = cos(t);
        a = (1 - co) / t2;
        b = (t - s) / (t2 * t);
        c3 = (t2 + 2 * co - 2) / (2 * t2 * t2);
        c4 = (2 * t - 3 * s + t * co) / (2 * t2 * t2 * t);
    }
    c2 = b;
    skew3(w, W);
    skew3(v, V);
    mm3(W, W, W2);
    /* exp(xi) = (Re, pe), Re = I + sin t/t W + a W^2, pe = (I + a W + b W^2) v */
    {
        double sinc = 1.0 - t2 * b; /* sin t / t */
        for (i = 0; i < 9; i++) {
            Re[i] = sinc * W[i] + a * W2[i];
            Vm[i] = a * W[i] + b * W2[i];
            J3[i] = -a * W[i] + b * W2[i];
        }
        for (i = 0; i < 3; i++) { Re[4 * i] += 1.0; Vm[4 * i] += 1.0; J3[4 * i] += 1.0; }
    }
    mv3(Vm, v, pe);
    mm3(W, V, WV);
    mm3(V, W, VW);
    mm3(WV, W, WVW);
    mm3(W, WV, WWV);
    mm3(VW, W, VWW);
    mm3(WVW, W, WVWW);
    mm3(W, WVW, WWVW);
    for (i = 0; i < 9; i++)
        Q[i] = -0.5 * V[i] + c2 * (WV[i] + VW[i] - WVW[i]) - c3 * (WWV[i] + VWW[i] - 3 * WVW[i]) + c4 * (WVWW[i] + WWVW[i]);
    memset(Jr, 0, 36 * sizeof(double));
    memset(J0, 0, 36 * sizeof(double));
    skew3(pe, P);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) tmp[3 * i + j] = Re[3 * j + i]; /* Re^T */
    mm3(tmp, P, RtP);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            Jr[6 * i + j] = J3[3 * i + j];
            Jr[6 * (3 + i) + 3 + j] = J3[3 * i + j];
            Jr[6 * i + 3 + j] = Q[3 * i + j];
            J0[6 * i + j] = tmp[3 * i + j];
            J0[6 * (3 + i) + 3 + j] = tmp[3 * i + j];
            J0[6 * i + 3 + j] = -RtP[3 * i + j];
        }
}

/* ------------------------------------------------------------------------------------ chart kinematics */
/* G(xi) V = V + [xi, V]/2 + [xi, [xi, V]]/12 on se(3) (the truncated inverse differential of exp). */
void pc_dexpinv_apply(const double* xi, const double* V, double* out) {
    double a[6], b[6];
    int i;
    cross_motion(xi, V, a);
    cross_motion(xi, a, b);
    for (i = 0; i < 6; i++) out[i] = V[i] + 0.5 * a[i] + b[i] / 12.0;
}

static void mm6(const double* A, const double* B, double* C) {
    int i, j, k;
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) {
            double s = 0.0;
            for (k = 0; k < 6; k++) s += A[6 * i + k] * B[6 * k + j];
            C[6 * i + j] = s;
        }
}

/* G = dexpinv(xi) (6x6) and Gx = d(G V)/d xi = -ad_V/2 - (ad_{[xi, V]} + ad_xi ad_V)/12. */
void pc_dexpinv_mats(const double* xi, const double* V, double* G, double* Gx) {
    double A[36], A2[36], adV[36], adAV[36], AadV[36], AV[6];
    int i;
    motion_cross_matrix(xi, A);
    mm6(A, A, A2);
    for (i = 0; i < 36; i++) G[i] = 0.5 * A[i] + A2[i] / 12.0;
    for (i = 0; i < 6; i++) G[6 * i + i] += 1.0;
    motion_cross_matrix(V, adV);
    mv6(A, V, AV);
    motion_cross_matrix(AV, adAV);
    mm6(A, adV, AadV);
    for (i = 0; i < 36; i++) Gx[i] = -0.5 * adV[i] - (adAV[i] + AadV[i]) / 12.0;
}

