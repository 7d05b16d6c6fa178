/*
 * postcapture plant core: the constant model. Owns reading the packed arrays into a pc_model_t,
 * pc_validate (every index and size checked before anything runs; afterwards the recursions trust the
 * model) and the tableau. Nothing here changes a model after pc_model_create returns it.
 *
 * Int array: header (PC_I_*), then joints (parent, kind, iq, iv), springs (v0, v1, k-scale index,
 * d-scale index), the input map (velocity index of each input), profiles (kind, channel, table offset,
 * table length), panels (root joint, tip joint, torsion index), arm velocity indices.
 * Double array: joints (R 9, p 3, dynamic parameters 10), springs (a0, a1, k, d, rest), the custom input
 * matrix (nv x nu, when flagged), profiles (start, stop, a, rise, w, phase, offset, f0, rate), table
 * times and values, panels (root frame R 9, p 3, tip point 3, length), accelerometer position (3), the
 * target map (10 x 10) and base (10), the nominal parameter vector (np).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "pc_internal.h"

#define PC_MAX_SIZE 1000000 /* any count above this is refused (keeps every size_t product far from overflow) */

#ifndef PC_BUILD_ID
#define PC_BUILD_ID "unversioned"
#endif

int pc_layout_version(void) { return PC_LAYOUT_VERSION; }
const char* pc_build_id(void) { return PC_BUILD_ID; }

/* Write a model's refusal into err (n bytes); returns PC_ERR_MODEL. */
int pc_model_error(char* err, size_t n, const char* fmt, ...) {
    va_list ap;
    if (err && n) {
        va_start(ap, fmt);
        vsnprintf(err, n, fmt, ap);
        va_end(ap);
    }
    return PC_ERR_MODEL;
}

/* ------------------------------------------------------------------------------------ allocation */
static void layout_model(pc_model_t* m, pc_carve_t* c) {
    size_t nj = (size_t)m->nj;
    m->joints = (pc_joint_t*)pc_carve(c, nj, sizeof(pc_joint_t));
    m->springs = (pc_spring_t*)pc_carve(c, (size_t)m->ns, sizeof(pc_spring_t));
    m->u_to_v = (int*)pc_carve(c, (size_t)m->nu, sizeof(int));
    m->B = (double*)pc_carve(c, (size_t)m->nv * (size_t)m->nu, sizeof(double));
    m->prof = (pc_profile_t*)pc_carve(c, (size_t)m->nprof, sizeof(pc_profile_t));
    m->table_t = (double*)pc_carve(c, (size_t)m->ntable, sizeof(double));
    m->table_v = (double*)pc_carve(c, (size_t)m->ntable, sizeof(double));
    m->panels = (pc_panel_t*)pc_carve(c, (size_t)m->npanels, sizeof(pc_panel_t));
    m->arm_v = (int*)pc_carve(c, (size_t)m->n_arm_v, sizeof(int));
    m->sub_end = (int*)pc_carve(c, nj, sizeof(int));
    m->p0 = (double*)pc_carve(c, (size_t)m->np, sizeof(double));
}

void pc_model_destroy(pc_model_t* m) {
    if (!m) return;
    free(m->block);
    free(m);
}

/* ------------------------------------------------------------------------------------ header */
static int read_header(pc_model_t* m, const int* ib, size_t n_ib, size_t n_db, char* err, size_t n) {
    size_t need_i, need_d;
    int k;
    if (!ib || n_ib < PC_I_HEADER) return pc_model_error(err, n, "packed model: %zu ints, fewer than the header's %d", n_ib, PC_I_HEADER);
    if (ib[PC_I_VERSION] != PC_LAYOUT_VERSION)
        return pc_model_error(err, n, "packed model: layout version %d, this core reads %d", ib[PC_I_VERSION], PC_LAYOUT_VERSION);
    for (k = 1; k < PC_I_HEADER; k++)
        if ((ib[k] < 0 && k != PC_I_TARGET_JOINT) || ib[k] > PC_MAX_SIZE)
            return pc_model_error(err, n, "packed model: header entry %d is %d, expected 0 to %d", k, ib[k], PC_MAX_SIZE);
    m->nq = ib[PC_I_NQ]; m->nv = ib[PC_I_NV]; m->nj = ib[PC_I_NJ]; m->nu = ib[PC_I_NU]; m->ns = ib[PC_I_NS];
    m->nprof = ib[PC_I_NPROF]; m->npanels = ib[PC_I_NFRAMES]; m->ntable = ib[PC_I_NTABLE];
    m->custom_b = ib[PC_I_CUSTOM_B]; m->n_arm = ib[PC_I_NARM]; m->n_arm_v = ib[PC_I_NARM_V];
    m->target_joint = ib[PC_I_TARGET_JOINT]; m->np = ib[PC_I_NP]; m->free_flyer = ib[PC_I_FREE_FLYER];
    if (m->free_flyer > 1 || m->custom_b > 1) return pc_model_error(err, n, "packed model: flags must be 0 or 1");
    if (m->nv < 1 || m->nj < 1) return pc_model_error(err, n, "packed model: expected at least one joint and one velocity");
    m->n_root_v = m->free_flyer ? 6 : 0;
    m->n_root_q = m->free_flyer ? 7 : 0;
    m->nz = 3 + m->n_arm;
    need_i = PC_I_HEADER + 4 * (size_t)m->nj + 4 * (size_t)m->ns + (size_t)m->nu + 4 * (size_t)m->nprof +
             3 * (size_t)m->npanels + (size_t)m->n_arm_v;
    need_d = 22 * (size_t)m->nj + 5 * (size_t)m->ns + (m->custom_b ? (size_t)m->nv * m->nu : 0) +
             9 * (size_t)m->nprof + 2 * (size_t)m->ntable + 16 * (size_t)m->npanels + 3 + 110 + (size_t)m->np;
    if (n_ib != need_i || n_db != need_d)
        return pc_model_error(err, n, "packed model: expected %zu ints and %zu doubles, found %zu and %zu", need_i, need_d, n_ib, n_db);
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ body */
static void read_body(pc_model_t* m, const int* ib, const double* db) {
    const int* ip = ib + PC_I_HEADER;
    const double* dp = db;
    int i;
    for (i = 0; i < m->nj; i++, ip += 4, dp += 22) {
        pc_joint_t* J = &m->joints[i];
        J->parent = ip[0]; J->kind = ip[1]; J->iq = ip[2]; J->iv = ip[3];
        memcpy(J->R, dp, 9 * sizeof(double)); memcpy(J->p, dp + 9, 3 * sizeof(double));
        memcpy(J->pi, dp + 12, 10 * sizeof(double));
        J->axis_only = J->kind >= 0 && J->R[0] == 1.0 && J->R[1] == 0.0 && J->R[2] == 0.0 && J->R[3] == 0.0 &&
                       J->R[4] == 1.0 && J->R[5] == 0.0 && J->R[6] == 0.0 && J->R[7] == 0.0 && J->R[8] == 1.0;
    }
    for (i = 0; i < m->ns; i++, ip += 4, dp += 5) {
        pc_spring_t* S = &m->springs[i];
        S->v[0] = ip[0]; S->v[1] = ip[1]; S->pk = ip[2]; S->pd = ip[3];
        S->a[0] = dp[0]; S->a[1] = dp[1]; S->k0 = dp[2]; S->d0 = dp[3]; S->rest = dp[4];
    }
    for (i = 0; i < m->nu; i++) m->u_to_v[i] = *ip++;
    if (m->custom_b) {
        memcpy(m->B, dp, (size_t)m->nv * m->nu * sizeof(double));
        dp += (size_t)m->nv * m->nu;
    }
    for (i = 0; i < m->nprof; i++, ip += 4, dp += 9) pc_profile_unpack(ip, dp, &m->prof[i]);
    memcpy(m->table_t, dp, (size_t)m->ntable * sizeof(double)); dp += m->ntable;
    memcpy(m->table_v, dp, (size_t)m->ntable * sizeof(double)); dp += m->ntable;
    for (i = 0; i < m->npanels; i++, ip += 3, dp += 16) {
        pc_panel_t* P = &m->panels[i];
        P->root_joint = ip[0]; P->tip_joint = ip[1]; P->torsion_v = ip[2];
        memcpy(P->R, dp, 9 * sizeof(double)); memcpy(P->p, dp + 9, 3 * sizeof(double));
        memcpy(P->tip, dp + 12, 3 * sizeof(double)); P->length = dp[15];
    }
    for (i = 0; i < m->n_arm_v; i++) m->arm_v[i] = *ip++;
    memcpy(m->r_acc, dp, 3 * sizeof(double)); dp += 3;
    memcpy(m->t_L, dp, 100 * sizeof(double)); dp += 100;
    memcpy(m->t_base, dp, 10 * sizeof(double)); dp += 10;
    memcpy(m->p0, dp, (size_t)m->np * sizeof(double));
}

/* What follows from a valid body: the input matrix, the subtree ranges, the spring pattern. */
static void derive(pc_model_t* m) {
    int i;
    if (!m->custom_b)
        for (i = 0; i < m->nu; i++)
            if (m->u_to_v[i] >= 0) m->B[(size_t)m->u_to_v[i] * m->nu + i] = 1.0;
    for (i = 0; i < m->nj; i++) m->sub_end[i] = i + 1;
    for (i = m->nj - 1; i >= 0; i--) {
        int p = m->joints[i].parent;
        if (p >= 0 && m->sub_end[i] > m->sub_end[p]) m->sub_end[p] = m->sub_end[i];
    }
    m->diag_springs = 1;
    for (i = 0; i < m->ns; i++)
        if (m->springs[i].v[1] >= 0) m->diag_springs = 0;
}

/* ------------------------------------------------------------------------------------ tableau */
static int read_tableau(pc_model_t* m, int s, const double* A, const double* b, const double* c, char* err, size_t n) {
    int i, j;
    pc_tableau_t* t = &m->tab;
    if (s < 1 || s > PC_MAX_STAGES || !A || !b || !c)
        return pc_model_error(err, n, "tableau: expected 1 to %d stages, found %d", PC_MAX_STAGES, s);
    memset(t, 0, sizeof *t);
    t->s = s;
    for (i = 0; i < s; i++) {
        for (j = 0; j < s; j++) {
            double a = A[s * i + j];
            if (!(fabs(a) < INFINITY)) return pc_model_error(err, n, "tableau: A[%d][%d] is not finite", i, j);
            if (j > i && a != 0.0) return pc_model_error(err, n, "tableau: A must be lower triangular, A[%d][%d] = %g", i, j, a);
            if (j <= i) t->A[i][j] = a;
        }
        if (!(fabs(b[i]) < INFINITY) || !(fabs(c[i]) < INFINITY)) return pc_model_error(err, n, "tableau: b[%d] or c[%d] is not finite", i, i);
        t->b[i] = b[i];
        t->c[i] = c[i];
    }
    t->stiffly_accurate = 1;
    for (j = 0; j < s; j++)
        if (t->A[s - 1][j] != b[j]) t->stiffly_accurate = 0;
    return PC_OK;
}

pc_model_t* pc_model_create(const int* ib, const double* db, size_t n_ib, size_t n_db, int s, const double* A,
                            const double* b, const double* c, char* err, size_t err_size) {
    pc_model_t* m = (pc_model_t*)calloc(1, sizeof *m);
    pc_carve_t cv = {NULL, 0};
    if (err && err_size) err[0] = '\0';
    if (!m) {
        pc_model_error(err, err_size, "out of memory for the model");
        return NULL;
    }
    if (read_header(m, ib, n_ib, n_db, err, err_size) || (n_db && !db) ||
        read_tableau(m, s, A, b, c, err, err_size))
        goto fail;
    layout_model(m, &cv);
    m->block = calloc(1, cv.used);
    if (!m->block) {
        pc_model_error(err, err_size, "out of memory for the model (%zu bytes)", cv.used);
        goto fail;
    }
    cv.base = (char*)m->block;
    cv.used = 0;
    layout_model(m, &cv);
    read_body(m, ib, db);
    if (pc_validate(m, err, err_size)) goto fail;
    derive(m);
    m->arena_size = pc_arena_need(m);
    return m;
fail:
    pc_model_destroy(m);
    return NULL;
}

int pc_sizes(const pc_model_t* m, int* out) {
    out[0] = m->nq; out[1] = m->nv; out[2] = m->nu; out[3] = m->np; out[4] = m->nz; out[5] = m->npanels;
    out[6] = m->nj; out[7] = m->tab.s;
    return PC_OK;
}

int pc_nominal_params(const pc_model_t* m, double* p) {
    memcpy(p, m->p0, (size_t)m->np * sizeof(double));
    return PC_OK;
}
