/*
 * postcapture estimator FMU: the instance the FMI 2.0 and 3.0 wrappers share (see pc_est_fmu.h). One
 * doStep is one filter cycle: the predictor inside (the engine's plant and exact Jacobians), then the
 * corrector with the inputs set for that step. A failed cycle puts the instance in the error state (the
 * getters, setting an FMU state, reset, terminate and free still work).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_est_fmu.h"

/* A serialised state: this header, then pc_est_save's doubles. */
typedef struct {
    uint32_t magic, size;
    int mode;
    double last_ok;
    double data[]; /* pc_est_state_size doubles */
} pce_state_t;

#define PCE_STATE_MAGIC 0x45534350u /* "PCSE" */

int pce_fmu_fail(pce_fmu_t* F, const char* function, const char* fmt, ...) {
    char buf[900], line[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    snprintf(line, sizeof line, "%s: %s", function, buf);
    if (F->log) F->log(F->env, F->name, PCE_FMU_ERROR, "logStatusError", line);
    return PCE_FMU_ERROR;
}

pce_fmu_t* pce_fmu_new(const char* function, const char* name, pce_logger_t log, void* env, int logging) {
    pce_fmu_t* F;
    char err[512] = "", line[700];
    if (!name) return NULL;
    F = (pce_fmu_t*)calloc(1, sizeof(pce_fmu_t));
    if (!F) return NULL;
    F->name = (char*)malloc(strlen(name) + 1);
    if (!F->name || pc_est_create(&F->E, err, sizeof err)) {
        snprintf(line, sizeof line, "%s: the estimator could not be created: %s", function, F->name ? err : "out of memory");
        if (log) log(env, name, PCE_FMU_ERROR, "logStatusError", line);
        free(F->name);
        free(F);
        return NULL;
    }
    strcpy(F->name, name);
    F->log = log;
    F->env = env;
    F->logging = logging;
    F->mode = PCE_MODE_INSTANTIATED;
    return F;
}

void pce_fmu_free(pce_fmu_t* F) {
    if (!F) return;
    pc_est_destroy(&F->E);
    free(F->name);
    free(F);
}

int pce_fmu_setup(pce_fmu_t* F, const char* function, double start_time) {
    if (F->mode != PCE_MODE_INSTANTIATED) return pce_fmu_fail(F, function, "only allowed after instantiation");
    if (!(fabs(start_time) < 1e15)) return pce_fmu_fail(F, function, "startTime %g is not a finite time", start_time);
    F->t0 = F->last_ok = start_time;
    return PCE_FMU_OK;
}

int pce_fmu_enter_init(pce_fmu_t* F, const char* function) {
    if (F->mode != PCE_MODE_INSTANTIATED) return pce_fmu_fail(F, function, "only allowed after instantiation");
    F->mode = PCE_MODE_INIT;
    return PCE_FMU_OK;
}

int pce_fmu_exit_init(pce_fmu_t* F, const char* function) {
    if (F->mode != PCE_MODE_INIT) return pce_fmu_fail(F, function, "only allowed in initialisation mode");
    if (pc_est_start(&F->E, F->t0)) return pce_fmu_fail(F, function, "%s", F->E.message);
    F->mode = PCE_MODE_STEP;
    return PCE_FMU_OK;
}

void pce_fmu_defaults(pce_fmu_t* F) {
    pc_est_defaults(&F->E);
    F->t0 = F->last_ok = 0.0;
    F->mode = PCE_MODE_INSTANTIATED;
}

/* ------------------------------------------------------------------------------------ values */
int pce_fmu_get(pce_fmu_t* F, const char* function, const unsigned* vr, size_t n, double* value) {
    size_t k;
    for (k = 0; k < n; k++) {
        if (vr[k] > PCE_VR_TIME) return pce_fmu_fail(F, function, "unknown value reference %u", vr[k]);
        value[k] = vr[k] == PCE_VR_TIME ? F->E.t : F->E.r[vr[k]];
    }
    return PCE_FMU_OK;
}

/* why a value may not be set now (NULL: it may) */
static const char* refusal(const pce_fmu_t* F, unsigned r, double v) {
    if (r >= PCE_NREAL || PCE_CAUSALITY[r] == 2) return "is not an input or a parameter";
    if (PCE_CAUSALITY[r] != 1) return NULL; /* an input: a non-finite value is a missing measurement */
    if (F->mode == PCE_MODE_STEP && !PCE_TUNABLE[r]) return "is fixed after initialisation";
    if (!(fabs(v) < INFINITY)) return "expected a finite number";
    if (PCE_POSITIVE[r] && !(v >= 0.0)) return "expected a number >= 0";
    return NULL;
}

int pce_fmu_set(pce_fmu_t* F, const char* function, const unsigned* vr, size_t n, const double* value) {
    size_t k;
    int retune = 0;
    if (F->mode == PCE_MODE_ERROR || F->mode == PCE_MODE_TERMINATED)
        return pce_fmu_fail(F, function, "not allowed in the %s state", F->mode == PCE_MODE_ERROR ? "error" : "terminated");
    for (k = 0; k < n; k++) { /* check all first: a refused call changes nothing */
        const char* why = refusal(F, vr[k], value[k]);
        if (why)
            return pce_fmu_fail(F, function, "%s = %g (value reference %u) %s", vr[k] < PCE_NREAL ? PCE_NAMES[vr[k]] : "?",
                                value[k], vr[k], why);
    }
    for (k = 0; k < n; k++) {
        F->E.r[vr[k]] = value[k]; /* a non-finite input is a missing measurement (counted at the step) */
        retune |= PCE_CAUSALITY[vr[k]] == 1;
    }
    if (retune && F->mode == PCE_MODE_STEP) pc_est_retune(&F->E);
    return PCE_FMU_OK;
}

/* ------------------------------------------------------------------------------------ step */
int pce_fmu_do_step(pce_fmu_t* F, const char* function, double t, double h) {
    if (F->mode != PCE_MODE_STEP)
        return pce_fmu_fail(F, function, F->mode == PCE_MODE_ERROR ? "the instance is in the error state (restore an "
                            "FMU state or reset it)" : "only allowed after initialisation");
    if (!(fabs(h - PCE_DT) <= 1e-9 * PCE_DT))
        return pce_fmu_fail(F, function, "communicationStepSize = %.17g: this estimator's step is its filter cycle, "
                            "%.17g s", h, PCE_DT);
    if (!(fabs(t - F->E.t) <= 1e-9 * (1.0 + fabs(t))))
        return pce_fmu_fail(F, function, "currentCommunicationPoint = %.17g: the estimates are at %.17g s", t, F->E.t);
    if (pc_est_cycle(&F->E, F->E.t, PCE_DT)) {
        F->mode = PCE_MODE_ERROR;
        return pce_fmu_fail(F, function, "the filter cycle at t = %.17g s failed: %s", t, F->E.message);
    }
    /* time never accumulates: the k-th cycle ends at t0 + k dt */
    F->E.t = F->t0 + (double)F->E.k * PCE_DT;
    F->last_ok = F->E.t;
    return PCE_FMU_OK;
}

/* ------------------------------------------------------------------------------------ FMU state */
size_t pce_fmu_state_bytes(pce_fmu_t* F) {
    return sizeof(pce_state_t) + pc_est_state_size(&F->E) * sizeof(double);
}

int pce_fmu_get_state(pce_fmu_t* F, const char* function, void** state) {
    pce_state_t* S;
    if (!F->E.started) return pce_fmu_fail(F, function, "only after initialisation");
    S = (pce_state_t*)(*state ? *state : malloc(pce_fmu_state_bytes(F)));
    if (!S) return pce_fmu_fail(F, function, "out of memory");
    S->magic = PCE_STATE_MAGIC;
    S->size = (uint32_t)pce_fmu_state_bytes(F);
    S->mode = F->mode;
    S->last_ok = F->last_ok;
    pc_est_save(&F->E, S->data);
    *state = S;
    return PCE_FMU_OK;
}

int pce_fmu_set_state(pce_fmu_t* F, const char* function, const void* state) {
    const pce_state_t* S = (const pce_state_t*)state;
    if (!F->E.started) return pce_fmu_fail(F, function, "only after initialisation");
    if (!S || S->magic != PCE_STATE_MAGIC || S->size != pce_fmu_state_bytes(F))
        return pce_fmu_fail(F, function, "not a state of this estimator");
    if (pc_est_load(&F->E, S->data)) return pce_fmu_fail(F, function, "refused: %s", F->E.message);
    F->mode = S->mode == PCE_MODE_ERROR ? PCE_MODE_STEP : S->mode;
    F->last_ok = S->last_ok;
    return PCE_FMU_OK;
}

void pce_fmu_free_state(void** state) {
    if (state && *state) {
        free(*state);
        *state = NULL;
    }
}

int pce_fmu_serialize(pce_fmu_t* F, const char* function, const void* state, char* bytes, size_t size) {
    if (!state || size != pce_fmu_state_bytes(F)) return pce_fmu_fail(F, function, "wrong size %lu", (unsigned long)size);
    memcpy(bytes, state, size);
    return PCE_FMU_OK;
}

int pce_fmu_deserialize(pce_fmu_t* F, const char* function, const char* bytes, size_t size, void** state) {
    pce_state_t* S;
    double* keep;
    double last_ok = F->last_ok;
    int st, mode = F->mode;
    if (size != pce_fmu_state_bytes(F))
        return pce_fmu_fail(F, function, "%lu bytes: not a state of this estimator", (unsigned long)size);
    S = (pce_state_t*)malloc(size);
    keep = (double*)malloc(pc_est_state_size(&F->E) * sizeof(double));
    if (!S || !keep) {
        free(S);
        free(keep);
        return pce_fmu_fail(F, function, "out of memory");
    }
    memcpy(S, bytes, size);
    /* checked now, against a scratch copy of this instance's state, so that a bad state is refused here */
    pc_est_save(&F->E, keep);
    st = pce_fmu_set_state(F, function, S);
    pc_est_load(&F->E, keep);
    F->mode = mode;
    F->last_ok = last_ok;
    free(keep);
    if (st != PCE_FMU_OK) {
        free(S);
        return st;
    }
    pce_fmu_free_state(state);
    *state = S;
    return PCE_FMU_OK;
}
