/*
 * postcapture plant core: the model's life cycle, read from the packed int and double arrays.
 *
 * Int array: header (PC_I_*), then joints (parent, kind, iq, iv), springs (v0, v1, k-scale index,
 * d-scale index), the input map (velocity index of each input), profiles (kind, channel, table offset,
 * table length), panels (root joint, tip joint, torsion index), arm velocity indices.
 * Double array: joints (R 9, p 3, dynamic parameters 10), springs (a0, a1, k, d, rest), the custom input
 * matrix (nv x nu, when flagged), profiles (start, stop, a, rise, w, phase, offset, f0, rate), table
 * times and values, panels (root frame R 9, p 3, tip point 3, length), accelerometer position (3), the target map (10 x 10) and base
 * (10), the nominal parameter vector (np).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "pc_internal.h"

void pc_set_error(pc_model_t* m, const char* fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m->error, sizeof m->error, fmt, ap);
    va_end(ap);
}

const char* pc_error_message(const pc_model_t* m) { return m->error; }

static void* zalloc(size_t n, size_t size, int* ok) {
    void* p = calloc(n ? n : 1, size);
    if (!p) *ok = 0;
    return p;
}

void pc_destroy(pc_model_t* m) {
    int i;
    if (!m) return;
    free(m->joints); free(m->springs); free(m->u_to_v); free(m->B); free(m->prof); free(m->table_t);
    free(m->table_v); free(m->panels); free(m->arm_v); free(m->params); free(m->u_extra); free(m->prev_V); free(m->prev2_V); free(m->prev2_v);
    free(m->prev_v); free(m->csl); free(m->fac.cs); free(m->Rl); free(m->pl); free(m->Ro); free(m->po); free(m->vj); free(m->aj); free(m->cj);
    free(m->fj); free(m->IA); free(m->Uj); free(m->Dj); free(m->uj);
    for (i = 0; i < 8; i++) free(m->tmp_nv[i]);
    for (i = 0; i < 2; i++) free(m->tmp_nq[i]);
    free(m->fac.R); free(m->fac.p); free(m->fac.U); free(m->fac.Dinv); free(m->dense); free(m->piv);
    free(m->jac_work);
    free(m);
}

static void default_tableau(pc_tableau_t* t) { /* Alexander's L-stable SDIRK3 */
    const double g = 0.43586652150845899941601945;
    memset(t, 0, sizeof *t);
    t->s = 3;
    t->A[0][0] = g;
    t->A[1][0] = (1 - g) / 2; t->A[1][1] = g;
    t->A[2][0] = -(6 * g * g - 16 * g + 1) / 4; t->A[2][1] = (6 * g * g - 20 * g + 5) / 4; t->A[2][2] = g;
    t->b[0] = t->A[2][0]; t->b[1] = t->A[2][1]; t->b[2] = g;
    t->c[0] = g; t->c[1] = (1 + g) / 2; t->c[2] = 1.0;
    t->stiffly_accurate = 1;
}

pc_model_t* pc_create(const int* ib, const double* db, size_t n_ib, size_t n_db) {
    pc_model_t* m;
    const int* ip;
    const double* dp;
    int i, ok = 1;
    size_t need_i, need_d;
    if (n_ib < PC_I_HEADER || ib[PC_I_VERSION] != PC_LAYOUT_VERSION) return NULL;
    m = (pc_model_t*)calloc(1, sizeof *m);
    if (!m) return NULL;
    m->nq = ib[PC_I_NQ]; m->nv = ib[PC_I_NV]; m->nj = ib[PC_I_NJ]; m->nu = ib[PC_I_NU]; m->ns = ib[PC_I_NS];
    m->nprof = ib[PC_I_NPROF]; m->npanels = ib[PC_I_NFRAMES]; m->ntable = ib[PC_I_NTABLE];
    m->custom_b = ib[PC_I_CUSTOM_B]; m->n_arm = ib[PC_I_NARM]; m->n_arm_v = ib[PC_I_NARM_V];
    m->target_joint = ib[PC_I_TARGET_JOINT]; m->np = ib[PC_I_NP]; m->free_flyer = ib[PC_I_FREE_FLYER];
    m->n_root_v = m->free_flyer ? 6 : 0;
    m->n_root_q = m->free_flyer ? 7 : 0;
    m->nz = 3 + m->n_arm;
    need_i = PC_I_HEADER + 4 * (size_t)m->nj + 4 * (size_t)m->ns + (size_t)m->nu + 4 * (size_t)m->nprof +
             3 * (size_t)m->npanels + (size_t)m->n_arm_v;
    need_d = 22 * (size_t)m->nj + 5 * (size_t)m->ns + (m->custom_b ? (size_t)m->nv * m->nu : 0) +
             9 * (size_t)m->nprof + 2 * (size_t)m->ntable + 16 * (size_t)m->npanels + 3 + 110 + (size_t)m->np;
    if (n_ib != need_i || n_db != need_d || m->nv <= 0 || m->nj <= 0) {
        pc_set_error(m, "packed model: expected %zu ints and %zu doubles, found %zu and %zu", need_i, need_d, n_ib, n_db);
        free(m);
        return NULL;
    }
    m->joints = (pc_joint_t*)zalloc((size_t)m->nj, sizeof(pc_joint_t), &ok);
    m->springs = (pc_spring_t*)zalloc((size_t)m->ns, sizeof(pc_spring_t), &ok);
    m->u_to_v = (int*)zalloc((size_t)m->nu, sizeof(int), &ok);
    m->B = (double*)zalloc((size_t)m->nv * m->nu, sizeof(double), &ok);
    m->prof = (pc_profile_t*)zalloc((size_t)m->nprof, sizeof(pc_profile_t), &ok);
    m->table_t = (double*)zalloc((size_t)m->ntable, sizeof(double), &ok);
    m->table_v = (double*)zalloc((size_t)m->ntable, sizeof(double), &ok);
    m->panels = (pc_panel_t*)zalloc((size_t)m->npanels, sizeof(pc_panel_t), &ok);
    m->arm_v = (int*)zalloc((size_t)m->n_arm_v, sizeof(int), &ok);
    m->params = (double*)zalloc((size_t)m->np, sizeof(double), &ok);
    m->u_extra = (double*)zalloc((size_t)m->nu, sizeof(double), &ok);
    m->prev_V = (double*)zalloc((size_t)PC_MAX_STAGES * m->nv, sizeof(double), &ok);
    m->prev_v = (double*)zalloc((size_t)m->nv, sizeof(double), &ok);
    m->prev2_V = (double*)zalloc((size_t)PC_MAX_STAGES * m->nv, sizeof(double), &ok);
    m->prev2_v = (double*)zalloc((size_t)m->nv, sizeof(double), &ok);
    m->Rl = (double*)zalloc((size_t)m->nj * 9, sizeof(double), &ok);
    m->csl = (double*)zalloc((size_t)m->nj * 2, sizeof(double), &ok);
    m->fac.cs = (double*)zalloc((size_t)m->nj * 2, sizeof(double), &ok);
    m->pl = (double*)zalloc((size_t)m->nj * 3, sizeof(double), &ok);
    m->Ro = (double*)zalloc((size_t)m->nj * 9, sizeof(double), &ok);
    m->po = (double*)zalloc((size_t)m->nj * 3, sizeof(double), &ok);
    m->vj = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->aj = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->cj = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->fj = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->IA = (double*)zalloc((size_t)m->nj * 36, sizeof(double), &ok);
    m->Uj = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->Dj = (double*)zalloc((size_t)m->nj, sizeof(double), &ok);
    m->uj = (double*)zalloc((size_t)m->nj, sizeof(double), &ok);
    for (i = 0; i < 8; i++) m->tmp_nv[i] = (double*)zalloc((size_t)m->nv, sizeof(double), &ok);
    for (i = 0; i < 2; i++) m->tmp_nq[i] = (double*)zalloc((size_t)m->nq, sizeof(double), &ok);
    m->fac.R = (double*)zalloc((size_t)m->nj * 9, sizeof(double), &ok);
    m->fac.p = (double*)zalloc((size_t)m->nj * 3, sizeof(double), &ok);
    m->fac.U = (double*)zalloc((size_t)m->nj * 6, sizeof(double), &ok);
    m->fac.Dinv = (double*)zalloc((size_t)m->nj, sizeof(double), &ok);
    m->dense = (double*)zalloc((size_t)m->nv * m->nv, sizeof(double), &ok);
    m->piv = (int*)zalloc((size_t)m->nv, sizeof(int), &ok);
    if (!ok) {
        pc_destroy(m);
        return NULL;
    }
    ip = ib + PC_I_HEADER;
    dp = db;
    for (i = 0; i < m->nj; i++) {
        pc_joint_t* J = &m->joints[i];
        J->parent = ip[0]; J->kind = ip[1]; J->iq = ip[2]; J->iv = ip[3];
        ip += 4;
        memcpy(J->R, dp, 9 * sizeof(double)); memcpy(J->p, dp + 9, 3 * sizeof(double));
        memcpy(J->pi, dp + 12, 10 * sizeof(double));
        dp += 22;
        J->axis_only = J->kind >= 0 && J->R[0] == 1.0 && J->R[1] == 0.0 && J->R[2] == 0.0 && J->R[3] == 0.0 &&
                       J->R[4] == 1.0 && J->R[5] == 0.0 && J->R[6] == 0.0 && J->R[7] == 0.0 && J->R[8] == 1.0;
        if (J->parent >= i || J->kind < -1 || J->kind > 2 || (J->kind == -1 && (i != 0 || J->parent != -1))) {
            pc_set_error(m, "joint %d: unsupported (free flyer only as the root; revolute x, y, z)", i);
            ok = 0;
        }
    }
    m->diag_springs = 1;
    for (i = 0; i < m->ns; i++) {
        pc_spring_t* S = &m->springs[i];
        S->v[0] = ip[0]; S->v[1] = ip[1]; S->pk = ip[2]; S->pd = ip[3];
        ip += 4;
        S->a[0] = dp[0]; S->a[1] = dp[1]; S->k0 = S->k = dp[2]; S->d0 = S->d = dp[3]; S->rest = dp[4];
        dp += 5;
        if (S->v[1] >= 0) m->diag_springs = 0;
    }
    for (i = 0; i < m->nu; i++) m->u_to_v[i] = *ip++;
    if (m->custom_b) {
        memcpy(m->B, dp, (size_t)m->nv * m->nu * sizeof(double));
        dp += (size_t)m->nv * m->nu;
    } else {
        for (i = 0; i < m->nu; i++)
            if (m->u_to_v[i] >= 0) m->B[(size_t)m->u_to_v[i] * m->nu + i] = 1.0;
    }
    for (i = 0; i < m->nprof; i++) {
        pc_profile_unpack(ip, dp, &m->prof[i]);
        ip += 4;
        dp += 9;
    }
    memcpy(m->table_t, dp, (size_t)m->ntable * sizeof(double)); dp += m->ntable;
    memcpy(m->table_v, dp, (size_t)m->ntable * sizeof(double)); dp += m->ntable;
    for (i = 0; i < m->npanels; i++) {
        pc_panel_t* P = &m->panels[i];
        P->root_joint = ip[0]; P->tip_joint = ip[1]; P->torsion_v = ip[2];
        ip += 3;
        memcpy(P->R, dp, 9 * sizeof(double)); memcpy(P->p, dp + 9, 3 * sizeof(double));
        memcpy(P->tip, dp + 12, 3 * sizeof(double)); P->length = dp[15];
        dp += 16;
    }
    for (i = 0; i < m->n_arm_v; i++) m->arm_v[i] = *ip++;
    memcpy(m->r_acc, dp, 3 * sizeof(double)); dp += 3;
    memcpy(m->t_L, dp, 100 * sizeof(double)); dp += 100;
    memcpy(m->t_base, dp, 10 * sizeof(double)); dp += 10;
    memcpy(m->params, dp, (size_t)m->np * sizeof(double));
    default_tableau(&m->tab);
    m->newton.rtol = 1e-10; m->newton.atol = 1e-15; m->newton.max_iter = 12;
    /* derivative scratch: generous, sized once */
    m->jac_work_size = (size_t)(2 * m->nv + m->nu + m->np + 8) * (size_t)(2 * m->nv) * (PC_MAX_STAGES * 2 + 8) +
                       (size_t)m->nv * m->nv * 8 + (size_t)m->nj * 64;
    m->jac_work = (double*)zalloc(m->jac_work_size, sizeof(double), &ok);
    if (!ok) {
        pc_destroy(m);
        return NULL;
    }
    if (m->np && pc_set_params(m, m->params)) {
        pc_destroy(m);
        return NULL;
    }
    return m;
}

int pc_sizes(const pc_model_t* m, int* out) {
    out[0] = m->nq; out[1] = m->nv; out[2] = m->nu; out[3] = m->np; out[4] = m->nz; out[5] = m->npanels;
    out[6] = m->nj;
    return PC_OK;
}

int pc_set_params(pc_model_t* m, const double* p) {
    int i, r, c;
    for (i = 0; i < m->np; i++)
        if (!(fabs(p[i]) < INFINITY)) {
            pc_set_error(m, "parameter %d is not finite", i);
            return PC_ERR_ARG;
        }
    if (p != m->params) memcpy(m->params, p, (size_t)m->np * sizeof(double));
    if (m->target_joint >= 0) {
        double* pi = m->joints[m->target_joint].pi;
        for (r = 0; r < 10; r++) {
            double s = m->t_base[r];
            for (c = 0; c < 10; c++) s += m->t_L[10 * r + c] * p[c];
            pi[r] = s;
        }
    }
    for (i = 0; i < m->ns; i++) {
        pc_spring_t* S = &m->springs[i];
        S->k = S->k0 * (S->pk >= 0 ? p[S->pk] : 1.0);
        S->d = S->d0 * (S->pd >= 0 ? p[S->pd] : 1.0);
    }
    m->fac.valid = 0;
    return PC_OK;
}

int pc_get_params(const pc_model_t* m, double* p) {
    memcpy(p, m->params, (size_t)m->np * sizeof(double));
    return PC_OK;
}

void pc_set_input_offset(pc_model_t* m, const double* u_extra) {
    if (u_extra) memcpy(m->u_extra, u_extra, (size_t)m->nu * sizeof(double));
    else memset(m->u_extra, 0, (size_t)m->nu * sizeof(double));
}

int pc_set_tableau(pc_model_t* m, int s, const double* A, const double* b, const double* c) {
    int i, j;
    if (s < 1 || s > PC_MAX_STAGES) {
        pc_set_error(m, "tableau: 1 to %d stages, found %d", PC_MAX_STAGES, s);
        return PC_ERR_ARG;
    }
    memset(&m->tab, 0, sizeof m->tab);
    m->tab.s = s;
    for (i = 0; i < s; i++) {
        for (j = 0; j <= i; j++) m->tab.A[i][j] = A[s * i + j];
        for (j = i + 1; j < s; j++)
            if (A[s * i + j] != 0.0) {
                pc_set_error(m, "tableau: A must be lower triangular");
                return PC_ERR_ARG;
            }
        m->tab.b[i] = b[i];
        m->tab.c[i] = c[i];
    }
    m->tab.stiffly_accurate = 1;
    for (j = 0; j < s; j++)
        if (m->tab.A[s - 1][j] != b[j]) m->tab.stiffly_accurate = 0;
    m->have_prev = 0;
    return PC_OK;
}

void pc_set_newton(pc_model_t* m, double rtol, double atol, int max_iter) {
    m->newton.rtol = rtol;
    m->newton.atol = atol;
    m->newton.max_iter = max_iter;
}

void pc_stats(const pc_model_t* m, long* out) {
    out[0] = m->n_steps; out[1] = m->n_newton; out[2] = m->n_factor;
}

void pc_reset_stats(pc_model_t* m) {
    m->n_steps = m->n_newton = m->n_factor = 0;
    m->have_prev = 0;
}
