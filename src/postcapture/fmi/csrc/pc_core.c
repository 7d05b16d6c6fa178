/*
 * postcapture FMU runtime: set-up, known inputs (the scenario's excitation), outputs and directional
 * derivatives. The integrator is in pc_step.c. Matrices from CasADi are column-major.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_core.h"

#define NQ PC_NQ
#define NV PC_NV
#define CM(A, nrows, r, c) ((A)[(c) * (nrows) + (r)]) /* column-major element */

void pc_logf(pc_inst_t* S, int status, const char* category, const char* fmt, ...) {
    char buf[1024];
    va_list ap;
    if (!S->log) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    S->log(S->log_env, status, category, buf);
}

/* ------------------------------------------------------------------------------------ set-up */
typedef int (*pc_work_fn)(int*, int*, int*, int*);

int pc_setup(pc_inst_t* S) {
    pc_work_fn fns[] = {pc_ddq_work, pc_ddq_jac_work, pc_ddq_jvp_work, pc_integ_work, pc_out_work,
                        pc_out_jvp_work, pc_meas_work,
#if PC_FREE_FLYER
                        pc_dint_work,
#endif
    };
    int na = 0, nr = 0, ni = 0, nw = 0;
    size_t k;
    for (k = 0; k < sizeof fns / sizeof fns[0]; k++) {
        int a, r, i, w;
        fns[k](&a, &r, &i, &w);
        if (a > na) na = a;
        if (r > nr) nr = r;
        if (i > ni) ni = i;
        if (w > nw) nw = w;
    }
    S->arg = (const double**)calloc((size_t)na + 1, sizeof(double*));
    S->res = (double**)calloc((size_t)nr + 1, sizeof(double*));
    S->iw = (int*)calloc((size_t)ni + 1, sizeof(int));
    S->w = (double*)calloc((size_t)nw + 1, sizeof(double));
    return (S->arg && S->res && S->iw && S->w) ? PC_OK : PC_ERROR;
}

void pc_teardown(pc_inst_t* S) {
    free((void*)S->arg);
    free(S->res);
    free(S->iw);
    free(S->w);
}

void pc_defaults(pc_inst_t* S) {
    int i;
    memset(&S->c, 0, sizeof S->c);
    memcpy(S->c.x, PC_X0, sizeof S->c.x);
    memcpy(S->c.xc, PC_X0, sizeof S->c.xc);
    memcpy(S->c.p, PC_P0, sizeof S->c.p);
    for (i = 0; i < PC_NJAC; i++) S->c.jac[i] = NAN;
    S->out_valid = 0;
}

/* ------------------------------------------------------------------------------------ inputs */
static double pc_profile(const pc_profile_t* P, double t, int left) {
    int on = left ? (P->start < t && t <= P->stop) : (P->start <= t && t < P->stop);
    if (!on) return 0.0;
    switch (P->kind) {
        case PC_PROFILE_STEP:
            if (P->rise == 0.0) return P->a;
            return P->a * fmin(fmin(1.0, (t - P->start) / P->rise), (P->stop - t) / P->rise);
        case PC_PROFILE_SINE:
            return P->offset + P->a * sin(P->w * (t - P->start) + P->phase);
        case PC_PROFILE_CHIRP: {
            double tau = t - P->start;
            return P->a * sin(PC_TWO_PI * (P->f0 * tau + 0.5 * P->rate * tau * tau) + P->phase);
        }
#if PC_NTABLE > 0
        case PC_PROFILE_TABLE: {
            const double* ts = PC_TABLE_T + P->table;
            const double* vs = PC_TABLE_V + P->table;
            int n = P->n_table, j;
            if (t <= ts[0]) return vs[0];
            if (t >= ts[n - 1]) return vs[n - 1];
            for (j = 0; j < n - 1 && !(t < ts[j + 1]); j++) {
            }
            return (vs[j + 1] - vs[j]) / (ts[j + 1] - ts[j]) * (t - ts[j]) + vs[j];
        }
#endif
    }
    return 0.0;
}

void pc_inputs(const pc_inst_t* S, double t, int left, double* u) {
    int i;
    for (i = 0; i < PC_NU; i++) u[i] = 0.0;
#if PC_NPROFILES > 0
    for (i = 0; i < PC_NPROFILES; i++) u[PC_PROFILES[i].channel] += pc_profile(&PC_PROFILES[i], t, left);
#endif
    for (i = 0; i < PC_NU; i++) u[i] += S->c.u[i];
}

/* ------------------------------------------------------------------------------------ calls */
int pc_call_ddq(pc_inst_t* S, const double* q, const double* v, const double* u, double* ddq) {
    S->arg[0] = q; S->arg[1] = v; S->arg[2] = u; S->arg[3] = S->c.p;
    S->res[0] = ddq;
    return pc_ddq(S->arg, S->res, S->iw, S->w, 0);
}

int pc_call_integ(pc_inst_t* S, const double* q, const double* xi, double* q1) {
    S->arg[0] = q; S->arg[1] = xi;
    S->res[0] = q1;
    return pc_integ(S->arg, S->res, S->iw, S->w, 0);
}

/* d ddq/d(q tangent), d ddq/dv, d ddq/dm at (q, v, u) into S->Aq, S->Av, S->dm (row-major). */
int pc_call_jac(pc_inst_t* S, const double* q, const double* v, const double* u, double* ddq) {
    int r, c;
    S->arg[0] = q; S->arg[1] = v; S->arg[2] = u; S->arg[3] = S->c.p;
    S->res[0] = ddq; S->res[1] = S->J;
    if (pc_ddq_jac(S->arg, S->res, S->iw, S->w, 0)) return PC_ERROR;
    for (r = 0; r < NV; r++) {
        for (c = 0; c < NV - PC_NE; c++) S->Aq[r * NV + c] = 0.0; /* the root's configuration */
        for (c = 0; c < PC_NE; c++) S->Aq[r * NV + NV - PC_NE + c] = CM(S->J, NV, r, c);
        for (c = 0; c < NV; c++) S->Av[r * NV + c] = CM(S->J, NV, r, PC_NE + c);
        S->dm[r] = PC_HAS_TARGET ? CM(S->J, NV, r, PC_NE + NV) : 0.0;
    }
    return PC_OK;
}


/* ------------------------------------------------------------------------------------ outputs */
int pc_update_outputs(pc_inst_t* S) {
    double u[PC_NU];
    if (S->out_valid) return PC_OK;
    pc_inputs(S, S->c.time, 0, u);
    if (pc_call_ddq(S, S->c.x, S->c.x + NQ, u, S->ddq)) return PC_ERROR;
    S->arg[0] = S->c.x; S->arg[1] = S->c.x + NQ; S->arg[2] = S->ddq;
    S->res[0] = S->xdot; S->res[1] = S->y;
    if (pc_out(S->arg, S->res, S->iw, S->w, 0)) return PC_ERROR;
    S->out_valid = 1;
    return PC_OK;
}

int pc_directional(pc_inst_t* S, const double* dx, const double* du, double* dxdot, double* dy) {
    double u[PC_NU], dddq[NV], dp[PC_NP];
    if (pc_update_outputs(S)) return PC_ERROR;
    memset(dp, 0, sizeof dp);
    pc_inputs(S, S->c.time, 0, u);
    S->arg[0] = S->c.x; S->arg[1] = S->c.x + NQ; S->arg[2] = u; S->arg[3] = S->c.p;
    S->arg[4] = dx; S->arg[5] = dx + NQ; S->arg[6] = du; S->arg[7] = dp;
    S->res[0] = dddq;
    if (pc_ddq_jvp(S->arg, S->res, S->iw, S->w, 0)) return PC_ERROR;
    S->arg[0] = S->c.x; S->arg[1] = S->c.x + NQ; S->arg[2] = S->ddq;
    S->arg[3] = dx; S->arg[4] = dx + NQ; S->arg[5] = dddq;
    S->res[0] = dxdot; S->res[1] = dy;
    return pc_out_jvp(S->arg, S->res, S->iw, S->w, 0) ? PC_ERROR : PC_OK;
}
