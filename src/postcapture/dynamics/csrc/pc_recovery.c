/*
 * postcapture engine: the failure model every filter shares (what estimation/filter.py describes). Owns the
 * chi-square gate of a measurement (none right after a recovery: re-acquisition), the rejections in a row
 * and the windowed NIS test that start a recovery, the recoveries within a window that mean divergence,
 * the divergence itself (counted, recorded, followed by the filter's re-initialisation), the covariance
 * check, the event log the Python side drains and words, and the pc_filter_* calls.
 */
#include <stdlib.h>

#include "pc_filter_internal.h"

size_t pc_book_doubles(const pc_policy_t* p) {
    /* NIS and dof windows (dofs stored as doubles' room), the window-bound table */
    return (size_t)PC_NKINDS * (size_t)p->nis_window * 2 + (size_t)p->n_window_bound + 1;
}

int pc_book_init(pc_book_t* b, const pc_policy_t* p, double* mem) {
    int i;
    if (p->nis_window < 0 || p->nis_window > PC_MAX_WINDOW || p->max_recoveries < 0 ||
        p->max_recoveries > PC_MAX_RECOVERIES || p->n_gate < 0 || p->n_gate > PC_GATE_MAX || p->reject_limit < 1 ||
        (p->nis_window > 0 && p->n_window_bound < 1))
        return PC_ERR_ARG;
    memset(b, 0, sizeof *b);
    b->reject_limit = p->reject_limit;
    b->nis_window = p->nis_window;
    b->max_recoveries = p->max_recoveries;
    b->gated = p->gated;
    b->n_gate = p->n_gate;
    b->n_window_bound = p->n_window_bound;
    b->inflation = p->inflation;
    b->gyro_bias_bump = p->gyro_bias_bump;
    b->recovery_window = p->recovery_window;
    for (i = 0; i < p->n_gate; i++) b->gate[i] = p->gate[i];
    b->nis_buf = mem;
    b->dof_buf = (int*)(mem + (size_t)PC_NKINDS * p->nis_window);
    b->window_bound = mem + (size_t)PC_NKINDS * p->nis_window * 2;
    for (i = 0; i < p->n_window_bound; i++) b->window_bound[i] = p->window_bound[i];
    b->status = PC_STATUS_RUNNING;
    return PC_OK;
}

static pc_event_t* new_event(pc_book_t* b, double t, int type, int cause, int kind) {
    pc_event_t* e;
    if (b->n_events == PC_EVENT_CAP) { /* the Python side drains after every call: keep the latest */
        memmove(b->events, b->events + 1, (PC_EVENT_CAP - 1) * sizeof(pc_event_t));
        b->n_events--;
    }
    e = &b->events[b->n_events++];
    memset(e, 0, sizeof *e);
    e->t = t;
    e->type = type;
    e->cause = cause;
    e->kind = kind;
    return e;
}

/* the gate of an m-dimensional innovation of a kind: < 0 when none */
double pc_book_gate(pc_book_t* b, int kind, int m) {
    if (b->reacquire[kind] || !b->gated || m < 1 || m > b->n_gate) return -1.0;
    return b->gate[m - 1];
}

void pc_book_missing(pc_book_t* b) { b->counts[PC_COUNT_MISSING]++; }

void pc_book_diverge(pc_book_t* b, double t, int cause, int n, const char* text) {
    pc_event_t* e;
    b->counts[PC_COUNT_DIVERGENCES]++;
    b->status = PC_STATUS_DIVERGED;
    e = new_event(b, t, PC_EV_DIVERGED, cause, -1);
    e->n = n;
    if (text) snprintf(e->text, sizeof e->text, "%s", text);
    b->rec_n = 0;
    memset(b->nis_len, 0, sizeof b->nis_len);
    memset(b->nis_head, 0, sizeof b->nis_head);
    b->reinitialise(b);
    new_event(b, t, PC_EV_REINITIALISED, PC_CAUSE_REINIT, -1);
    b->status = PC_STATUS_RECOVERING;
    b->reacquire[PC_KIND_STAR] = b->reacquire[PC_KIND_GYRO] = b->reacquire[PC_KIND_ACCELERATIONS] = 1;
}

static void start_recovery(pc_book_t* b, int kind, double t, const pc_cause_t* why) {
    pc_event_t* e;
    int i, drop = 0;
    b->rejected_in_row[kind] = 0;
    b->nis_len[kind] = b->nis_head[kind] = 0;
    while (drop < b->rec_n && b->rec_t[drop] < t - b->recovery_window) drop++;
    for (i = drop; i < b->rec_n; i++) b->rec_t[i - drop] = b->rec_t[i];
    b->rec_n -= drop;
    b->rec_t[b->rec_n++] = t;
    if (b->rec_n > b->max_recoveries) {
        int n = b->rec_n;
        pc_book_diverge(b, t, PC_CAUSE_TOO_MANY, n, NULL);
        /* the divergence event is the one before the re-initialisation */
        e = &b->events[b->n_events - 2];
        e->a = b->recovery_window;
        e->inner_cause = why->cause;
        e->inner_kind = why->kind;
        e->inner_n = why->n;
        e->inner_a = why->a;
        e->inner_b = why->b;
        return;
    }
    b->counts[PC_COUNT_RECOVERIES]++;
    b->status = PC_STATUS_RECOVERING;
    e = new_event(b, t, PC_EV_RECOVERING, why->cause, why->kind);
    e->n = why->n;
    e->a = why->a;
    e->b = why->b;
    b->recover(b, kind);
}

/* one update, accepted or rejected: counts, then a recovery when the innovations call for one */
void pc_book_record(pc_book_t* b, int kind, double t, double nis, int dof, int accepted) {
    int w = b->nis_window, i, len, dofs;
    double total;
    b->reacquire[kind] = 0;
    if (!accepted) {
        int n;
        b->counts[PC_COUNT_REJECTED]++;
        n = ++b->rejected_in_row[kind];
        if (n >= b->reject_limit) {
            pc_cause_t why = {PC_CAUSE_REJECTED_RUN, kind, n, nis, 0.0};
            start_recovery(b, kind, t, &why);
        }
        return;
    }
    b->counts[PC_COUNT_UPDATES]++;
    b->rejected_in_row[kind] = 0;
    if (!w) return;
    {
        double* buf = b->nis_buf + (size_t)kind * w;
        int* dbuf = b->dof_buf + (size_t)kind * w;
        int head = b->nis_head[kind];
        len = b->nis_len[kind];
        /* a ring of the last w: head is the oldest */
        if (len < w) {
            buf[(head + len) % w] = nis;
            dbuf[(head + len) % w] = dof;
            b->nis_len[kind] = ++len;
        } else {
            buf[head] = nis;
            dbuf[head] = dof;
            b->nis_head[kind] = head = (head + 1) % w;
        }
        if (len < w) return;
        total = 0.0;
        dofs = 0;
        for (i = 0; i < w; i++) {
            total += buf[(head + i) % w];
            dofs += dbuf[(head + i) % w];
        }
    }
    if (dofs < b->n_window_bound && total > b->window_bound[dofs]) {
        pc_cause_t why = {PC_CAUSE_NIS_WINDOW, kind, w, total / w, (double)dofs / w};
        start_recovery(b, kind, t, &why);
    } else if (b->status == PC_STATUS_RECOVERING) {
        b->status = PC_STATUS_RUNNING;
        new_event(b, t, PC_EV_RECOVERED, PC_CAUSE_CONSISTENT, kind);
    }
}

/* 1 when P (n x n) is finite with a non-negative diagonal; otherwise a divergence and 0 */
int pc_book_check(pc_book_t* b, const double* P, int n, double t, int after_update) {
    int i, ok = 1;
    for (i = 0; i < n * n && ok; i++) ok = fabs(P[i]) < INFINITY;
    for (i = 0; i < n && ok; i++) ok = P[(size_t)i * n + i] >= 0.0;
    if (!ok) pc_book_diverge(b, t, PC_CAUSE_COVARIANCE, after_update, NULL);
    return ok;
}

/* P <- P * outer(d, d) with d = sqrt(factor) on the indices, 1 elsewhere */
void pc_inflate(double* P, int N, const int* index, int n_index, double factor) {
    int i, j, k;
    double s = sqrt(factor);
    for (k = 0; k < n_index; k++) {
        i = index[k];
        for (j = 0; j < N; j++) P[(size_t)i * N + j] *= s;
        for (j = 0; j < N; j++) P[(size_t)j * N + i] *= s;
    }
}

/* ------------------------------------------------------------------------------------ pc_filter_* */
int pc_filter_status(const void* f, long* counts) {
    const pc_book_t* b = (const pc_book_t*)f;
    if (counts) memcpy(counts, b->counts, sizeof b->counts);
    return b->status;
}

int pc_filter_events(void* f, double* out, char* text, int cap) {
    pc_book_t* b = (pc_book_t*)f;
    int i, n = b->n_events < cap ? b->n_events : cap;
    for (i = 0; i < n; i++) {
        const pc_event_t* e = &b->events[i];
        double* o = out + (size_t)i * PC_EVD_SIZE;
        o[PC_EVD_T] = e->t;
        o[PC_EVD_TYPE] = e->type;
        o[PC_EVD_CAUSE] = e->cause;
        o[PC_EVD_KIND] = e->kind;
        o[PC_EVD_N] = e->n;
        o[PC_EVD_A] = e->a;
        o[PC_EVD_B] = e->b;
        o[PC_EVD_INNER_CAUSE] = e->inner_cause;
        o[PC_EVD_INNER_KIND] = e->inner_kind;
        o[PC_EVD_INNER_N] = e->inner_n;
        o[PC_EVD_INNER_A] = e->inner_a;
        o[PC_EVD_INNER_B] = e->inner_b;
        memcpy(text + (size_t)i * PC_EVENT_TEXT, e->text, PC_EVENT_TEXT);
    }
    memmove(b->events, b->events + n, (size_t)(b->n_events - n) * sizeof(pc_event_t));
    b->n_events -= n;
    return n;
}

const char* pc_filter_message(const void* f) { return ((const pc_book_t*)f)->message; }

double* pc_filter_state(void* f, size_t* n) {
    pc_book_t* b = (pc_book_t*)f;
    if (n) *n = b->n_state;
    return b->state;
}

void pc_filter_destroy(void* f) { free(f); }

/* the book's numbers (no pointers, no pending events), then the filter's state array */
#define BOOK_FIXED (2 + PC_NCOUNTS + 4 * PC_NKINDS + PC_MAX_RECOVERIES + 1)

size_t pc_filter_save_size(const void* f) {
    const pc_book_t* b = (const pc_book_t*)f;
    return BOOK_FIXED + 2 * (size_t)PC_NKINDS * b->nis_window + b->n_state;
}

void pc_filter_save(const void* f, double* o) {
    const pc_book_t* b = (const pc_book_t*)f;
    int i;
    size_t n = (size_t)PC_NKINDS * b->nis_window;
    *o++ = b->status;
    *o++ = b->rec_n;
    for (i = 0; i < PC_NCOUNTS; i++) *o++ = (double)b->counts[i];
    for (i = 0; i < PC_NKINDS; i++) {
        *o++ = b->rejected_in_row[i];
        *o++ = b->reacquire[i];
        *o++ = b->nis_len[i];
        *o++ = b->nis_head[i];
    }
    for (i = 0; i <= PC_MAX_RECOVERIES; i++) *o++ = b->rec_t[i];
    for (i = 0; i < (int)n; i++) *o++ = b->nis_buf[i];
    for (i = 0; i < (int)n; i++) *o++ = b->dof_buf[i];
    memcpy(o, b->state, b->n_state * sizeof(double));
}

void pc_filter_load(void* f, const double* o) {
    pc_book_t* b = (pc_book_t*)f;
    int i;
    size_t n = (size_t)PC_NKINDS * b->nis_window;
    b->status = (int)*o++;
    b->rec_n = (int)*o++;
    for (i = 0; i < PC_NCOUNTS; i++) b->counts[i] = (long)*o++;
    for (i = 0; i < PC_NKINDS; i++) {
        b->rejected_in_row[i] = (int)*o++;
        b->reacquire[i] = (int)*o++;
        b->nis_len[i] = (int)*o++;
        b->nis_head[i] = (int)*o++;
    }
    for (i = 0; i <= PC_MAX_RECOVERIES; i++) b->rec_t[i] = *o++;
    for (i = 0; i < (int)n; i++) b->nis_buf[i] = *o++;
    for (i = 0; i < (int)n; i++) b->dof_buf[i] = (int)*o++;
    memcpy(b->state, o, b->n_state * sizeof(double));
    b->n_events = 0;
}
