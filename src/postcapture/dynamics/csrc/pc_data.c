/*
 * postcapture plant core: one instance's data. Owns the data's life cycle (one allocation at
 * pc_data_create, none afterwards), the scratch arena every call takes its temporary arrays from
 * (a stack: a call marks it, allocates, and releases to the mark; its size is fixed per model by
 * pc_arena_need, so a step cannot run out of memory midway), the error buffer, the parameter vector
 * (validated, then applied to the joint inertias and spring coefficients), the input offset, the
 * Newton settings and the statistics.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "pc_internal.h"

void pc_set_error(pc_data_t* d, const char* fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(d->error, sizeof d->error, fmt, ap);
    va_end(ap);
}

const char* pc_error_message(const pc_data_t* d) { return d->error; }

/* ------------------------------------------------------------------------------------ arena */
double* pc_arena_alloc(pc_data_t* d, size_t n) {
    size_t top = d->arena_top + ((n + 1) & ~(size_t)1); /* keep 16-byte alignment */
    double* p;
    if (top > d->arena_size) {
        pc_set_error(d, "scratch arena exhausted (%zu of %zu doubles): a bug in pc_arena_need", top, d->arena_size);
        return NULL;
    }
    p = d->arena + d->arena_top; /* not zeroed: every user writes what it reads */
    d->arena_top = top;
    if (top > d->arena_peak) d->arena_peak = top;
    return p;
}

/* The deepest stack of temporaries any call takes (doubles), summed over the nested users:
 * the stages of a step, the step-Jacobian sensitivities, the chained prediction Jacobians, the
 * measurement Jacobians, the forward-dynamics partials and the inverse-dynamics derivative pass. */
size_t pc_arena_need(const pc_model_t* m) {
    size_t nv = (size_t)m->nv, nu = (size_t)m->nu, np = (size_t)m->np, nq = (size_t)m->nq, nj = (size_t)m->nj;
    size_t nt = 2 * nv, nc = nt + nu + np;
    size_t stages = PC_MAX_STAGES * (4 * nv + nu + 2) + 4 * nv + nq + 16;
    size_t sens = (PC_MAX_STAGES + 3) * nt * nc + 3 * nv * nv + nv * nu + nv * np + nv * nc + 16;
    size_t chain = nt * nt + nt * nu + nt * np + nt * nc + 16;
    size_t measure = 3 * (nu + 2) + 2 * nv * nv + nv * (nu + np + 2) + 2 * nv * nv + nv * (np + 2) + 2 * nv + 80;
    size_t partials = 2 * nv + nv * np + 16;
    size_t rnea_der = 24 * nv + 140 * nj + 64;
    size_t gravity = 12 * nj + 16;
    return stages + sens + chain + measure + partials + rnea_der + gravity + 256;
}

/* ------------------------------------------------------------------------------------ life cycle */
/* Reserve n items of size bytes in one block (aligned to 16); with base NULL only counts the size. */
void* pc_carve(pc_carve_t* c, size_t n, size_t size) {
    size_t start = (c->used + 15) & ~(size_t)15;
    c->used = start + (n ? n : 1) * size;
    return c->base ? c->base + start : NULL;
}

static void factor_layout(pc_factor_t* F, pc_carve_t* c, size_t nj) {
    F->R = (double*)pc_carve(c, nj * 9, sizeof(double));
    F->p = (double*)pc_carve(c, nj * 3, sizeof(double));
    F->U = (double*)pc_carve(c, nj * 6, sizeof(double));
    F->Dinv = (double*)pc_carve(c, nj, sizeof(double));
    F->cs = (double*)pc_carve(c, nj * 2, sizeof(double));
}

static void layout_data(const pc_model_t* m, pc_data_t* d, pc_carve_t* c) {
    size_t nj = (size_t)m->nj, nv = (size_t)m->nv;
    int i;
    d->params = (double*)pc_carve(c, (size_t)m->np, sizeof(double));
    d->pi = (double*)pc_carve(c, nj * 10, sizeof(double));
    d->k = (double*)pc_carve(c, (size_t)m->ns, sizeof(double));
    d->dmp = (double*)pc_carve(c, (size_t)m->ns, sizeof(double));
    d->u_extra = (double*)pc_carve(c, (size_t)m->nu, sizeof(double));
    d->prev_V = (double*)pc_carve(c, PC_MAX_STAGES * nv, sizeof(double));
    d->prev_v = (double*)pc_carve(c, nv, sizeof(double));
    d->prev2_V = (double*)pc_carve(c, PC_MAX_STAGES * nv, sizeof(double));
    d->prev2_v = (double*)pc_carve(c, nv, sizeof(double));
    d->Rl = (double*)pc_carve(c, nj * 9, sizeof(double));
    d->pl = (double*)pc_carve(c, nj * 3, sizeof(double));
    d->csl = (double*)pc_carve(c, nj * 2, sizeof(double));
    d->Ro = (double*)pc_carve(c, nj * 9, sizeof(double));
    d->po = (double*)pc_carve(c, nj * 3, sizeof(double));
    d->vj = (double*)pc_carve(c, nj * 6, sizeof(double));
    d->aj = (double*)pc_carve(c, nj * 6, sizeof(double));
    d->cj = (double*)pc_carve(c, nj * 6, sizeof(double));
    d->fj = (double*)pc_carve(c, nj * 6, sizeof(double));
    d->IA = (double*)pc_carve(c, nj * 36, sizeof(double));
    d->Uj = (double*)pc_carve(c, nj * 6, sizeof(double));
    d->Dj = (double*)pc_carve(c, nj, sizeof(double));
    d->uj = (double*)pc_carve(c, nj, sizeof(double));
    for (i = 0; i < 8; i++) d->tmp_nv[i] = (double*)pc_carve(c, nv, sizeof(double));
    for (i = 0; i < 2; i++) d->tmp_nq[i] = (double*)pc_carve(c, (size_t)m->nq, sizeof(double));
    factor_layout(&d->fac, c, nj);
    factor_layout(&d->fac2, c, nj);
    d->dense = (double*)pc_carve(c, nv * nv, sizeof(double));
    d->dense2 = (double*)pc_carve(c, nv * nv, sizeof(double));
    d->piv = (int*)pc_carve(c, nv, sizeof(int));
    d->arena = (double*)pc_carve(c, m->arena_size, sizeof(double));
}

pc_data_t* pc_data_create(const pc_model_t* m) {
    pc_data_t* d = (pc_data_t*)calloc(1, sizeof *d);
    pc_carve_t c = {NULL, 0};
    if (!d) return NULL;
    layout_data(m, d, &c);
    d->block = calloc(1, c.used);
    if (!d->block) {
        free(d);
        return NULL;
    }
    c.base = (char*)d->block;
    c.used = 0;
    layout_data(m, d, &c);
    d->arena_size = m->arena_size;
    d->newton.rtol = 1e-10; d->newton.atol = 1e-15; d->newton.max_iter = 12;
    if (pc_set_params(m, d, m->p0)) { /* a model whose nominal parameters are not physical */
        pc_data_destroy(d);
        return NULL;
    }
    return d;
}

void pc_data_destroy(pc_data_t* d) {
    if (!d) return;
    free(d->block);
    free(d);
}

int pc_data_copy(const pc_model_t* m, pc_data_t* dst, const pc_data_t* src) {
    int err = pc_set_params(m, dst, src->params);
    if (err) return err;
    memcpy(dst->u_extra, src->u_extra, (size_t)m->nu * sizeof(double));
    dst->newton = src->newton;
    dst->orbit_n = src->orbit_n;
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ parameters */
/* The target hub of ten parameters is a body: positive mass, inertia about its centre of mass positive
 * definite (leading minors). */
static int physical_hub(const double* p) {
    double m = p[0], c[3], I[9], cc;
    int i;
    if (!(m > 0.0)) return 0;
    for (i = 0; i < 3; i++) c[i] = p[1 + i] / m;
    cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    I[0] = p[4] - m * (cc - c[0] * c[0]); I[4] = p[6] - m * (cc - c[1] * c[1]); I[8] = p[9] - m * (cc - c[2] * c[2]);
    I[1] = I[3] = p[5] + m * c[0] * c[1];
    I[2] = I[6] = p[7] + m * c[0] * c[2];
    I[5] = I[7] = p[8] + m * c[1] * c[2];
    return I[0] > 0.0 && I[0] * I[4] - I[1] * I[3] > 0.0 &&
           I[0] * (I[4] * I[8] - I[5] * I[7]) - I[1] * (I[3] * I[8] - I[5] * I[6]) + I[2] * (I[3] * I[7] - I[4] * I[6]) > 0.0;
}

/* Why p is not a parameter vector of this model (finite, scales >= 0, a physical hub), in err. */
int pc_params_problem(const pc_model_t* m, const double* p, char* err, size_t n) {
    int i, n_inertial = m->target_joint >= 0 ? 10 : 0;
    for (i = 0; i < m->np; i++) {
        if (!(fabs(p[i]) < INFINITY)) {
            snprintf(err, n, "parameter %d is %g: expected a finite number", i, p[i]);
            return PC_ERR_ARG;
        }
        if (i >= n_inertial && p[i] < 0.0) {
            snprintf(err, n, "parameter %d is %g: expected a scale >= 0", i, p[i]);
            return PC_ERR_ARG;
        }
    }
    if (n_inertial && !physical_hub(p)) {
        snprintf(err, n, "parameters 0-9 (the target hub): expected a positive mass and an inertia about the centre "
                         "of mass that is positive definite, found mass %g", p[0]);
        return PC_ERR_ARG;
    }
    return PC_OK;
}

int pc_set_params(const pc_model_t* m, pc_data_t* d, const double* p) {
    int i, r, c, err = pc_params_problem(m, p, d->error, sizeof d->error);
    if (err) return err;
    if (p != d->params) memcpy(d->params, p, (size_t)m->np * sizeof(double));
    for (i = 0; i < m->nj; i++) memcpy(d->pi + 10 * i, m->joints[i].pi, 10 * sizeof(double));
    if (m->target_joint >= 0) {
        double* pi = d->pi + 10 * m->target_joint;
        for (r = 0; r < 10; r++) {
            double s = m->t_base[r];
            for (c = 0; c < 10; c++) s += m->t_L[10 * r + c] * p[c];
            pi[r] = s;
        }
    }
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        d->k[i] = S->k0 * (S->pk >= 0 ? p[S->pk] : 1.0);
        d->dmp[i] = S->d0 * (S->pd >= 0 ? p[S->pd] : 1.0);
    }
    d->fac.valid = 0;
    return PC_OK;
}

int pc_get_params(const pc_model_t* m, const pc_data_t* d, double* p) {
    memcpy(p, d->params, (size_t)m->np * sizeof(double));
    return PC_OK;
}

/* ------------------------------------------------------------------------------------ settings */
int pc_set_input_offset(const pc_model_t* m, pc_data_t* d, const double* u_extra) {
    int i;
    if (!u_extra) {
        memset(d->u_extra, 0, (size_t)m->nu * sizeof(double));
        return PC_OK;
    }
    for (i = 0; i < m->nu; i++)
        if (!(fabs(u_extra[i]) < INFINITY)) {
            pc_set_error(d, "input offset %d is %g: expected a finite number", i, u_extra[i]);
            return PC_ERR_ARG;
        }
    memcpy(d->u_extra, u_extra, (size_t)m->nu * sizeof(double));
    return PC_OK;
}

int pc_set_newton(pc_data_t* d, double rtol, double atol, int max_iter) {
    if (!(rtol >= 0.0 && rtol < 1.0) || !(atol >= 0.0 && atol < INFINITY) || !(rtol > 0.0 || atol > 0.0) ||
        max_iter < 1 || max_iter > 1000) {
        pc_set_error(d, "Newton settings (rtol %g, atol %g, max_iter %d): expected 0 <= rtol < 1, atol >= 0, one of "
                        "them > 0, 1 to 1000 iterations", rtol, atol, max_iter);
        return PC_ERR_ARG;
    }
    d->newton.rtol = rtol;
    d->newton.atol = atol;
    d->newton.max_iter = max_iter;
    return PC_OK;
}

void pc_stats(const pc_data_t* d, long* out) {
    out[0] = d->n_steps; out[1] = d->n_newton; out[2] = d->n_factor; out[3] = (long)d->arena_peak;
}

void pc_reset_stats(pc_data_t* d) {
    d->n_steps = d->n_newton = d->n_factor = 0;
    d->have_prev = 0;
}

int pc_stages_alloc(const pc_model_t* m, pc_data_t* d, pc_stages_t* S) {
    int i, nv = m->nv;
    size_t per = 4 * (size_t)nv + (size_t)m->nu;
    double* buf = pc_arena_alloc(d, per * PC_MAX_STAGES);
    if (!buf) return PC_ERR_MEMORY;
    for (i = 0; i < PC_MAX_STAGES; i++) {
        double* b = buf + per * i;
        S->xi[i] = b; S->V[i] = b + nv; S->Kxi[i] = b + 2 * nv; S->Kv[i] = b + 3 * nv; S->u[i] = b + 4 * nv;
    }
    return PC_OK;
}
