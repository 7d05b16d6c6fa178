/*
 * postcapture engine (internal): what the filter files share. Which file owns what:
 *   pc_recovery.c      the failure model of every filter: gates, rejections in a row, windowed NIS,
 *                      recoveries, divergence and re-initialisation, the event log, the pc_filter_* calls
 *   pc_kalman.c        the Joseph update with gating and Schmidt consider states, small dense products
 *   pc_so3.c           the filters' attitude maps (scalar-first box-plus, box-minus, Exp, inverse Jacobians)
 *   pc_increments.c    the gyro's mean rate and the accelerometer's mean specific force over a cycle, the
 *                      triad calibration
 *   pc_parameters.c    the log-Cholesky map and the map of the filters' parameter coordinates
 *   pc_mekf.c          the MEKF
 *   pc_attitude_ekf.c  the attitude EKF's error-state arithmetic
 *   pc_mass_filter.c   the sigmoid mass filter
 *   pc_augmented.c     the augmented error-state EKF over a plant instance
 */
#ifndef PC_FILTER_INTERNAL_H
#define PC_FILTER_INTERNAL_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pc_filter.h"

#define PC_MAX_WINDOW 1024
#define PC_MAX_RECOVERIES 64
#define PC_EVENT_CAP 64
#define PC_GATE_MAX PC_MAX_MEAS

typedef struct {
    double t, a, b, inner_a, inner_b;
    int type, cause, kind, n, inner_cause, inner_kind, inner_n;
    char text[PC_EVENT_TEXT];
} pc_event_t;

/* A recovery's cause, kept until it is logged (or wrapped in a divergence's). */
typedef struct {
    int cause, kind, n;
    double a, b;
} pc_cause_t;

/* Every filter struct starts with this. */
typedef struct pc_book {
    int status;
    long counts[PC_NCOUNTS];
    int rejected_in_row[PC_NKINDS];
    int reacquire[PC_NKINDS];
    int nis_len[PC_NKINDS], nis_head[PC_NKINDS];
    double* nis_buf;     /* PC_NKINDS x nis_window */
    int* dof_buf;        /* PC_NKINDS x nis_window */
    double rec_t[PC_MAX_RECOVERIES + 1];
    int rec_n;
    pc_event_t events[PC_EVENT_CAP];
    int n_events;
    /* policy (copied) */
    int reject_limit, nis_window, max_recoveries, gated, n_gate, n_window_bound;
    double inflation, gyro_bias_bump, recovery_window;
    double gate[PC_GATE_MAX];
    double* window_bound;
    /* the filter's hooks and state */
    void (*recover)(void* f, int kind);
    void (*reinitialise)(void* f);
    double* state;
    size_t n_state;
    char message[256];
} pc_book_t;

/* pc_recovery.c */
size_t pc_book_doubles(const pc_policy_t* p); /* doubles of the book's own arrays (windows, bound table) */
int pc_book_init(pc_book_t* b, const pc_policy_t* p, double* mem);
double pc_book_gate(pc_book_t* b, int kind, int m);
void pc_book_record(pc_book_t* b, int kind, double t, double nis, int dof, int accepted);
void pc_book_diverge(pc_book_t* b, double t, int cause, int n, const char* text);
int pc_book_check(pc_book_t* b, const double* P, int n, double t, int after_update);
void pc_book_missing(pc_book_t* b);
void pc_inflate(double* P, int N, const int* index, int n_index, double factor);

/* pc_kalman.c */
void pc_sym_predict(int n, double* P, const double* Phi, const double* Q, double* ws); /* P <- sym(Phi P Phi^T + Q) */
void pc_symmetrize(double* P, int n);
int pc_kf_run(pc_book_t* b, int kind, double t, int n, int m, double* P, const double* nu, const double* H,
              const double* R, const unsigned char* consider, double* dx, double* K, pc_update_t* res, double* ws);

/* pc_so3.c: quaternions scalar first */
void pc_q_normalize(double* q);
void pc_q_box_plus(const double* q, const double* d, double* out);
void pc_q_box_minus(const double* q1, const double* q2, double* d);
void pc_q_from_xyzw(const double* xyzw, double* q);
void pc_exp_matrix(const double* phi, double* E);
void pc_jr_inv(const double* phi, double* J);
void pc_skew(const double* v, double* S);
void pc_mm3(const double* A, const double* B, double* C);

#endif
