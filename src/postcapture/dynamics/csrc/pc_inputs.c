/*
 * postcapture plant core: the known inputs. Owns the excitation profiles (the only implementation of
 * their formulas: the model's inputs and the Python InputSchedule, through pc_inputs_eval, both
 * evaluate them here), the instance's constant input offset and the input map tau += B u.
 */
#include "pc_internal.h"

void pc_profile_unpack(const int* ip, const double* dp, pc_profile_t* P) {
    P->kind = ip[0]; P->channel = ip[1]; P->table = ip[2]; P->n_table = ip[3];
    P->start = dp[0]; P->stop = dp[1]; P->a = dp[2]; P->rise = dp[3]; P->w = dp[4]; P->phase = dp[5];
    P->offset = dp[6]; P->f0 = dp[7]; P->rate = dp[8];
}

static double table_value(const pc_profile_t* P, const double* table_t, const double* table_v, double t) {
    const double* ts = table_t + P->table;
    const double* vs = table_v + P->table;
    int n = P->n_table, j;
    if (t <= ts[0]) return vs[0];
    if (t >= ts[n - 1]) return vs[n - 1];
    for (j = 0; j < n - 2 && !(t < ts[j + 1]); j++) {
    }
    return vs[j] + (vs[j + 1] - vs[j]) * ((t - ts[j]) / (ts[j + 1] - ts[j]));
}

static double profile_value(const pc_profile_t* P, const double* table_t, const double* table_v, double t, int left) {
    int on = left ? (P->start < t && t <= P->stop) : (P->start <= t && t < P->stop);
    if (!on) return 0.0;
    switch (P->kind) {
        case PC_PROFILE_STEP: {
            double r;
            if (P->rise == 0.0) return P->a;
            r = fmin(1.0, (t - P->start) / P->rise);
            return P->a * fmin(r, (P->stop - t) / P->rise);
        }
        case PC_PROFILE_SINE:
            return P->offset + P->a * sin(P->w * (t - P->start) + P->phase);
        case PC_PROFILE_CHIRP: {
            double tau = t - P->start;
            return P->a * sin(2.0 * 3.141592653589793 * (P->f0 * tau + 0.5 * P->rate * tau * tau) + P->phase);
        }
        case PC_PROFILE_TABLE:
            return table_value(P, table_t, table_v, t);
    }
    return 0.0;
}

void pc_inputs_at(const pc_model_t* m, const pc_data_t* d, double t, int left, double* u) {
    int i;
    for (i = 0; i < m->nu; i++) u[i] = 0.0;
    for (i = 0; i < m->nprof; i++)
        u[m->prof[i].channel] += profile_value(&m->prof[i], m->table_t, m->table_v, t, left);
    for (i = 0; i < m->nu; i++) u[i] += d->u_extra[i];
}

int pc_inputs(const pc_model_t* m, const pc_data_t* d, double t, int left, double* u) {
    pc_inputs_at(m, d, t, left, u);
    return PC_OK;
}

int pc_inputs_eval(int nprof, const int* prof_i, const double* prof_d, int ntable, const double* table_t,
                   const double* table_v, int nu, int n_times, const double* t, int left, double* u_out) {
    int i, k;
    size_t n;
    if (nprof < 0 || ntable < 0 || nu < 0 || n_times < 0) return PC_ERR_ARG;
    for (i = 0; i < nprof; i++) { /* the packed layout as pack_profiles writes it, checked before any use */
        pc_profile_t P;
        pc_profile_unpack(prof_i + 4 * (size_t)i, prof_d + 9 * (size_t)i, &P);
        if (P.kind < PC_PROFILE_STEP || P.kind > PC_PROFILE_TABLE || P.channel < 0 || P.channel >= nu) return PC_ERR_ARG;
        if (P.kind == PC_PROFILE_TABLE && (P.n_table < 2 || P.table < 0 || P.table > ntable - P.n_table)) return PC_ERR_ARG;
    }
    for (n = 0; n < (size_t)n_times * (size_t)nu; n++) u_out[n] = 0.0;
    for (i = 0; i < nprof; i++) {
        pc_profile_t P;
        pc_profile_unpack(prof_i + 4 * (size_t)i, prof_d + 9 * (size_t)i, &P);
        for (k = 0; k < n_times; k++)
            u_out[(size_t)k * nu + P.channel] += profile_value(&P, table_t, table_v, t[k], left);
    }
    return PC_OK;
}

/* tau += B u */
void pc_input_force(const pc_model_t* m, const double* u, double* tau) {
    int i, j;
    if (m->custom_b) {
        for (i = 0; i < m->nv; i++)
            for (j = 0; j < m->nu; j++) tau[i] += m->B[(size_t)i * m->nu + j] * u[j];
    } else {
        for (j = 0; j < m->nu; j++)
            if (m->u_to_v[j] >= 0) tau[m->u_to_v[j]] += u[j];
    }
}
