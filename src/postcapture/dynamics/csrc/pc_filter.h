/*
 * postcapture engine: the filters' public interface. The Kalman arithmetic of every estimator (the
 * MEKF, the attitude EKF, the sigmoid mass filter and the augmented error-state EKF over a plant
 * instance), their shared failure model (gating, recoveries, divergence) and their measurement models,
 * in plain C99. The same sources run behind the Python filters (postcapture.estimation, loaded with
 * ctypes) and inside the estimator FMUs.
 *
 * A filter is one allocation made at its creation; no call allocates afterwards. Every filter struct
 * starts with a pc_book_t, so the pc_filter_* calls (status, counts, events) take any of them. Matrices
 * are row-major; quaternions here are scalar first (w, x, y, z), as in the Python package (the plant's
 * configuration keeps Pinocchio's x y z w, converted where the filters read it). Every int-returning
 * call returns a PC_* status (pc_plant.h); a filter's last failure is explained by pc_filter_message.
 */
#ifndef PC_FILTER_H
#define PC_FILTER_H

#include "pc_plant.h"

/* measurement kinds (the recovery bookkeeping keeps one record per kind) */
enum { PC_KIND_STAR = 0, PC_KIND_GYRO = 1, PC_KIND_ACCEL = 2, PC_KIND_ENCODERS = 3, PC_KIND_ACCELERATIONS = 4,
       PC_NKINDS = 5 };
enum { PC_STATUS_RUNNING = 0, PC_STATUS_RECOVERING = 1, PC_STATUS_DIVERGED = 2 };
/* events and their causes (the Python side words them) */
enum { PC_EV_RECOVERING = 0, PC_EV_RECOVERED = 1, PC_EV_DIVERGED = 2, PC_EV_REINITIALISED = 3 };
enum {
    PC_CAUSE_REJECTED_RUN = 0, /* n samples in a row rejected, a = last NIS */
    PC_CAUSE_NIS_WINDOW = 1,   /* a = mean NIS over n updates, b = dof each */
    PC_CAUSE_CONSISTENT = 2,   /* recovered */
    PC_CAUSE_TOO_MANY = 3,     /* n recoveries within a seconds; inner_*: the last recovery's cause */
    PC_CAUSE_COVARIANCE = 4,   /* P not finite or a negative variance; n = 0 after the prediction, 1 after an update */
    PC_CAUSE_S_NONFINITE = 5,  /* the innovation covariance is not finite */
    PC_CAUSE_S_NOT_PD = 6,     /* ... not positive definite */
    PC_CAUSE_PLANT = 7,        /* the plant copy failed: text */
    PC_CAUSE_REINIT = 8        /* re-initialised */
};
/* counters of pc_filter_counts */
enum { PC_COUNT_UPDATES = 0, PC_COUNT_REJECTED, PC_COUNT_MISSING, PC_COUNT_RECOVERIES, PC_COUNT_DIVERGENCES,
       PC_COUNT_INPUTS_MISSING, PC_NCOUNTS };

#define PC_MAX_MEAS 32    /* largest measurement of one update */
#define PC_EVENT_TEXT 200
/* the numbers of one event, as pc_filter_events writes them: 12 doubles per event */
enum { PC_EVD_T = 0, PC_EVD_TYPE, PC_EVD_CAUSE, PC_EVD_KIND, PC_EVD_N, PC_EVD_A, PC_EVD_B, PC_EVD_INNER_CAUSE,
       PC_EVD_INNER_KIND, PC_EVD_INNER_N, PC_EVD_INNER_A, PC_EVD_INNER_B, PC_EVD_SIZE };

/* How a filter recovers (estimation.filter.RecoveryPolicy) and gates: gate[m - 1] is the chi-square gate of an
 * m-dimensional innovation (gated = 0: none), window_bound[d] the bound of a window's NIS sum with d degrees
 * of freedom (d < n_window_bound). */
typedef struct {
    int reject_limit, nis_window, max_recoveries, gated, n_gate, n_window_bound;
    double inflation, gyro_bias_bump, recovery_window;
    const double* gate;
    const double* window_bound;
} pc_policy_t;

/* One update's outcome (m <= PC_MAX_MEAS): the innovation, its covariance, the NIS and the gate. */
typedef struct {
    int m, accepted, missing;
    double nis, threshold; /* threshold < 0: no gate */
    double innovation[PC_MAX_MEAS];
    double S[PC_MAX_MEAS * PC_MAX_MEAS];
} pc_update_t;

/* any filter: status and counters (PC_NCOUNTS), the events since the last call (out: PC_EVD_SIZE doubles and
 * PC_EVENT_TEXT chars each, at most cap; returns how many), the last failure, its state (one contiguous array
 * whose layout each filter's create states: what a snapshot copies), free */
PC_API int pc_filter_status(const void* f, long* counts);
PC_API int pc_filter_events(void* f, double* out, char* text, int cap);
PC_API const char* pc_filter_message(const void* f);
PC_API double* pc_filter_state(void* f, size_t* n);
/* a filter's whole state (its state array and its failure model's), as doubles: what an FMU state saves */
PC_API size_t pc_filter_save_size(const void* f);
PC_API void pc_filter_save(const void* f, double* buf);
PC_API void pc_filter_load(void* f, const double* buf);
PC_API void pc_filter_destroy(void* f);

/* the Kalman kernel: Joseph update of a zero error state with gating and consider states (consider: n flags
 * or NULL), on P in place; dx (n) and K (n x m) may be NULL. Returns 0, or PC_ERR_SINGULAR (S not positive
 * definite) / PC_ERR_NONFINITE (S not finite) with P unchanged. ws: pc_kf_workspace(n, m) doubles. */
PC_API size_t pc_kf_workspace(int n, int m);
PC_API void pc_kf_predict(int n, double* P, const double* F, const double* Q, double* ws); /* sym(F P F^T + Q), ws 2n^2 */
PC_API int pc_kf_update(int n, int m, double* P, const double* nu, const double* H, const double* R,
                        const unsigned char* consider, double threshold, double* dx, double* K, pc_update_t* res,
                        double* ws);

/* the inertial sensors' increments over a cycle (pc_increments.c); quaternions scalar first; J: the six 3 x 3
 * derivatives att1, att0, v1, w1, v0, w0 (54 doubles) */
PC_API void pc_mean_rate(const double* q0, const double* q1, double dt, double* z, double* H1, double* H0,
                         double* phi);
PC_API void pc_mean_specific_force(const double* phi, const double* v0, const double* w0, const double* v1,
                                   const double* w1, const double* r, double dt, double* z, double* J);
PC_API void pc_tidal_mean(const double* q0, const double* r0, const double* q1, const double* r1, const double* rB,
                          double n, double t0, double t1, double* out);
PC_API void pc_triad_matrix(const double* c, double* C);
PC_API void pc_triad_sensitivity(const double* w, double* D);

/* the filters' parameter coordinates (pc_parameters.c): the log-Cholesky map of ten inertial parameters
 * (pi and d pi / d theta, 10 x 10, may be NULL), and p(eta) with d p / d eta (n_p x n_eta, may be NULL) for a
 * map of blocks: spec = [n_blocks, then per block: kind (0: ten log-Cholesky coordinates, 1: logarithms of
 * factors), size, the size model indices]; the coordinates not in the map stay at p_nominal */
PC_API void pc_log_cholesky(const double* theta, double* pi, double* dpi);
PC_API int pc_parammap_size(const int* spec, int n_spec, int n_p);
PC_API void pc_parammap_apply(const int* spec, const double* p_nominal, int n_p, const double* eta, double* p,
                              double* J);

/* MEKF (pc_mekf.c): m = 6, or 15 with the gyro's scale factors and misalignments.
 * state: [q (4), bias (3), calibration (m - 6), t, P (m x m)] */
typedef struct pc_mekf pc_mekf_t;
PC_API pc_mekf_t* pc_mekf_create(int m, const double* q0, const double* bias0, const double* P0, double t0,
                                 double sigma_v, double sigma_u, double reacquire_attitude, double reacquire_bias,
                                 const pc_policy_t* policy);
PC_API int pc_mekf_predict(pc_mekf_t* f, double t, double dt, const double* u);
PC_API int pc_mekf_update(pc_mekf_t* f, double t, const double* q_meas, const double* R, pc_update_t* res);
PC_API void pc_mekf_transition(const double* w, double dt, double* Phi6); /* the error's Phi over dt (6 x 6) */
PC_API void pc_mekf_noise(double sigma_v, double sigma_u, double dt, double* Q6); /* its process noise (6 x 6) */
PC_API void pc_mekf_retune(pc_mekf_t* f, double sigma_v, double sigma_u);

/* attitude EKF (pc_attitude_ekf.c): the error-state arithmetic (its plant copy steps and retracts outside).
 * state: [P (3 x 3)] */
typedef struct pc_atekf pc_atekf_t;
PC_API pc_atekf_t* pc_atekf_create(const double* P0, const double* Q, double reacquire_attitude,
                                   const pc_policy_t* policy);
PC_API int pc_atekf_predict(pc_atekf_t* f, double t, const double* Fa, const double* Q_extra);
PC_API int pc_atekf_update(pc_atekf_t* f, double t, const double* q_meas, const double* q_est, const double* R,
                           double* dtheta, double* K, pc_update_t* res);
PC_API void pc_atekf_retune(pc_atekf_t* f, const double* Q);

/* sigmoid mass filter (pc_mass_filter.c): theta = b + (a - b) / (1 + exp(-c x)).
 * state: [x, accelerometer bias (n_bias), P ((1 + n_bias)^2)] */
typedef struct pc_massf pc_massf_t;
PC_API pc_massf_t* pc_massf_create(int n_bias, double x0, double P0, double P0_bias, double q_start, double q_end,
                                   double q_bias, double a, double b, double c, double t0, double t_end,
                                   const pc_policy_t* policy);
PC_API int pc_massf_predict(pc_massf_t* f, double t);
PC_API double pc_massf_noise(const pc_massf_t* f, double t); /* the variance the prediction at t adds to x's */
PC_API int pc_massf_update(pc_massf_t* f, double t, int m, const double* nu, const double* dz, const double* R,
                           pc_update_t* res);
PC_API void pc_sigmoid(double a, double b, double c, double x, double* theta, double* slope);
PC_API void pc_massf_estimate(const pc_massf_t* f, double* theta, double* sigma); /* theta and its 1-sigma */
PC_API void pc_massf_retune(pc_massf_t* f, double q_start, double q_end, double q_bias);

/* the reference's dual scheme between its filters and its plant copy (pc_refdual.c; estimation/dual.py):
 * S1 = F S + g; s_att <- (I - K) s_att after an accepted star-tracker update; the mass uncertainty's process
 * noise on the attitude Q = d d^T with d = s_rate dt sigma; the devices' prediction over a step from the plant
 * states at its ends and its derivative along the sensitivities s0, s1 (attitude, velocity, rate: 9 each) and
 * s1_arm (z, dz: 3 + n_arm) */
PC_API void pc_rdual_propagate(int n, const double* F, const double* g, const double* S, double* S1);
PC_API void pc_rdual_lean(const double* K, double* s_att);
PC_API void pc_rdual_mass_noise(const double* s_rate, double dt, double sigma, double* Q);
PC_API void pc_rdual_devices(const double* q0, const double* q1, const double* v0, const double* w0, const double* v1,
                             const double* w1, const double* r, double dt, const double* s0, const double* s1,
                             int n_arm, const double* angles1, const double* s1_arm, double* z, double* dz);
/* a target's ten inertial parameters: d pi / d m at a fixed centre of mass and inertia about it, and pi with the
 * hub's mass set to m (PC_ERR_ARG unless m > 0 and pi[0] > 0) */
PC_API void pc_dmass_direction(const double* pi, double* d);
PC_API int pc_target_mass(const double* pi, double m, double* out);

/* augmented EKF (pc_augmented.c) over a plant instance (it borrows m and d for its lifetime), or over a plant
 * that steps outside (pc_aug_create_external: another process model, an FMU; a free-flyer root with Euclidean
 * joints, x = [q (nq, the root's quaternion x y z w at 3), v (nv)]). Either way one set of filter equations:
 * pc_aug_predict takes the instance's step, pc_aug_predict_given a step taken outside, then both run the same
 * clone, propagation, noise and check.
 * state: [x (nx), gyro bias (3), accelerometer bias (3), gyro calibration (n_cal), eta (n_eta), clone: q (4),
 * v (3), w (3), dt, t, P (N x N)] */
typedef struct pc_aug pc_aug_t;
typedef struct {
    int n_arm, n_cal, n_consider, full_noise; /* full_noise: q_noise is n x n, else one variance per velocity */
    int n_spec;
    const int* arm_v;      /* velocity index of each encoder's joint */
    const int* param_spec; /* pc_parammap_apply's spec */
    const double* p_nominal;
    double step, r_accel[3];
    double sigma_gyro_walk, sigma_accel_walk;
    double mean_motion; /* of the orbit whose tidal field the accelerometer's model takes out (0: free space) */
    int frozen_jacobian; /* 1: the cycle's first model step's Jacobian taken for all its steps (pc_predict's 2) */
} pc_aug_config_t;
PC_API pc_aug_t* pc_aug_create(const pc_model_t* m, pc_data_t* d, const pc_aug_config_t* cfg, const double* x0,
                               const double* eta0, const double* P0, const double* q_noise, const pc_policy_t* policy,
                               char* err, size_t err_size);
/* without a plant instance: cfg->step is not used (the outside model checks its own steps) */
PC_API pc_aug_t* pc_aug_create_external(int nq, int nv, int np, const pc_aug_config_t* cfg, const double* x0,
                                        const double* eta0, const double* P0, const double* q_noise,
                                        const pc_policy_t* policy, char* err, size_t err_size);
PC_API int pc_aug_sizes(const pc_aug_t* f, int* out); /* N, n, nx, n_eta, np, n_cal */
/* over the plant instance: its step with the parameters of eta; a failed step is a divergence (re-initialised,
 * tried again), a second failure returns its status */
PC_API int pc_aug_predict(pc_aug_t* f, double t, double dt);
/* the plant's parameters for the current eta: p (np) and J = dp / deta (np x n_eta), either may be NULL; what
 * a plant stepping outside is set to before its step */
PC_API int pc_aug_plant_params(pc_aug_t* f, double* p, double* J);
/* a step taken outside from the filter's x over [t, t + dt] with the parameters of pc_aug_plant_params: x1 (nx),
 * F = d x1 / d x (n x n) and Fp = d x1 / d p (n x np), in the tangent of pc_predict (right perturbations of q,
 * then v); PC_ERR_ARG for a non-finite value */
PC_API int pc_aug_predict_given(pc_aug_t* f, double t, double dt, const double* x1, const double* F,
                                const double* Fp);
/* the plant outside could not take the step: pc_aug_predict's divergence (status and text go into its event);
 * the caller tries again with the re-initialised parameters, and a second failure is its to report */
PC_API void pc_aug_plant_failed(pc_aug_t* f, double t, int status, const char* text);
PC_API int pc_aug_update(pc_aug_t* f, int kind, double t, const double* value, const double* R, pc_update_t* res);
PC_API int pc_aug_measure(pc_aug_t* f, int kind, double* z, double* H); /* gyro, accelerometer, encoders: z, H (m x N) */
PC_API void pc_aug_apply(pc_aug_t* f, const double* dx); /* x <- x (+) dx over the whole error state */
PC_API int pc_aug_parameters(pc_aug_t* f, double* p, double* C); /* p (np), C (np x np) or NULL */
PC_API void pc_aug_reopen(pc_aug_t* f, int index, double sigma);
PC_API void pc_aug_retune(pc_aug_t* f, const double* q_noise, double sigma_gyro_walk, double sigma_accel_walk);

#endif
