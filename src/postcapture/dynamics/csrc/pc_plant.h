/*
 * postcapture plant core: the flexible multibody plant, its Lie-group integrators, step Jacobians and
 * outputs, in plain C99 (libm only). The same sources run behind the Python package (loaded with
 * ctypes from a per-machine build) and inside exported FMUs (compiled with the model data embedded).
 *
 * The model is data, not code: a tree of joints (a free-flyer root or a fixed base, revolute joints
 * about x, y or z), their placements and inertias, linear springs and dampers on the joint angles, the
 * input map, the excitation profiles and the output frames, packed by postcapture.dynamics.packing into
 * one int array and one double array (layout below).
 *
 * Conventions (Pinocchio's): twists and wrenches are (linear, angular); a placement (R, p) of a child
 * frame in its parent maps child coordinates to parent ones; the root's configuration is
 * (position, quaternion x y z w) and its velocity the body twist; tangent perturbations of the
 * configuration are right perturbations. Matrices are row-major.
 */
#ifndef PC_PLANT_H
#define PC_PLANT_H

#include <stddef.h>

#define PC_LAYOUT_VERSION 4

/* Symbols of the Python-facing library; an FMU build defines PC_API empty (only fmi2* are exported). */
#ifndef PC_API
#define PC_API __attribute__((visibility("default")))
#endif

/* header of the int array */
enum {
    PC_I_VERSION = 0, PC_I_NQ, PC_I_NV, PC_I_NJ, PC_I_NU, PC_I_NS, PC_I_NPROF, PC_I_NFRAMES, PC_I_NTABLE,
    PC_I_CUSTOM_B, PC_I_NARM, PC_I_NARM_V, PC_I_TARGET_JOINT, PC_I_NP, PC_I_FREE_FLYER, PC_I_HEADER
};

enum { PC_PROFILE_STEP = 0, PC_PROFILE_SINE = 1, PC_PROFILE_CHIRP = 2, PC_PROFILE_TABLE = 3 };
enum { PC_OK = 0, PC_ERR_NEWTON = 1, PC_ERR_NONFINITE = 2, PC_ERR_SINGULAR = 3, PC_ERR_ARG = 4, PC_ERR_MEMORY = 5 };

#define PC_MAX_STAGES 8

/* One excitation profile on one input channel, active on [start, stop). */
typedef struct {
    int kind, channel, table, n_table;
    double start, stop, a, rise, w, phase, offset, f0, rate;
} pc_profile_t;

typedef struct {
    int parent;      /* parent joint (-1: the universe) */
    int kind;        /* -1 free flyer, 0/1/2 revolute about x/y/z */
    int iq, iv;      /* first configuration / velocity index */
    double R[9], p[3]; /* placement in the parent joint's frame */
    double pi[10];   /* inertia: Pinocchio dynamic parameters in the joint frame */
    int axis_only;   /* revolute with an identity placement rotation: its rotation is about one axis */
} pc_joint_t;

typedef struct {
    int v[2];        /* velocity indices of the (at most two) coordinates, -1 when unused */
    double a[2];     /* coefficients: deflection a . q - rest */
    double k0, d0;   /* nominal stiffness and damping */
    double k, d;     /* current (scaled) values */
    double rest;
    int pk, pd;      /* parameter index of the stiffness and damping scale (-1: none) */
} pc_spring_t;

/* A panel's output frames: its root frame (on the host body) and its tip point (on the last segment). */
typedef struct {
    int root_joint, tip_joint, torsion_v;
    double R[9], p[3]; /* root frame placement in the root joint's frame */
    double tip[3];     /* tip point in the tip joint's frame */
    double length;
} pc_panel_t;

/* A Butcher tableau with a lower-triangular A. */
typedef struct {
    int s;
    double A[PC_MAX_STAGES][PC_MAX_STAGES], b[PC_MAX_STAGES], c[PC_MAX_STAGES];
    int stiffly_accurate;
} pc_tableau_t;

typedef struct pc_model pc_model_t;

/* Newton policy of the implicit stages: per-coordinate weights 1 / (atol + rtol |y_i|), accepted once
 * the RMS of the weighted correction is below 1 after at least two iterations, or below 0.1 at the first. */
typedef struct {
    double rtol, atol;
    int max_iter;
} pc_newton_t;

/* life cycle */
PC_API pc_model_t* pc_create(const int* ib, const double* db, size_t n_ib, size_t n_db);
PC_API void pc_destroy(pc_model_t* m);
PC_API const char* pc_error_message(const pc_model_t* m);
PC_API int pc_sizes(const pc_model_t* m, int* out); /* nq, nv, nu, np, nz, npanels, nj */
PC_API int pc_set_params(pc_model_t* m, const double* p);
PC_API int pc_get_params(const pc_model_t* m, double* p);
PC_API void pc_set_input_offset(pc_model_t* m, const double* u_extra);
PC_API int pc_set_tableau(pc_model_t* m, int s, const double* A, const double* b, const double* c);
PC_API void pc_set_newton(pc_model_t* m, double rtol, double atol, int max_iter);
PC_API void pc_stats(const pc_model_t* m, long* out); /* steps, newton iterations, factorizations */
PC_API void pc_reset_stats(pc_model_t* m);

/* dynamics */
PC_API void pc_inputs(const pc_model_t* m, double t, int left, double* u);
/* The excitation without a model: nprof profiles and their tables packed as in the model arrays (ints
 * kind, channel, table offset, table length; doubles start, stop, a, rise, w, phase, offset, f0, rate),
 * summed per channel at n_times times t into u_out (n_times x nu, row-major); left: left limits. */
PC_API int pc_inputs_eval(int nprof, const int* prof_i, const double* prof_d, int ntable, const double* table_t,
                          const double* table_v, int nu, int n_times, const double* t, int left, double* u_out);
PC_API void pc_force(const pc_model_t* m, const double* q, const double* v, const double* u, double* tau);
PC_API int pc_aba(pc_model_t* m, const double* q, const double* v, const double* tau, double* ddq);
PC_API int pc_rnea(pc_model_t* m, const double* q, const double* v, const double* a, double* tau);
PC_API int pc_accel(pc_model_t* m, const double* q, const double* v, const double* u, double* ddq);
PC_API int pc_integrate(const pc_model_t* m, const double* q, const double* dq, double* q1);
PC_API int pc_difference(const pc_model_t* m, const double* q0, const double* q1, double* dq);
PC_API int pc_derivatives(pc_model_t* m, const double* q, const double* v, const double* u, double* ddq, double* Aq,
                   double* Av, double* Au, double* Ap);
PC_API int pc_mass_matrix(pc_model_t* m, const double* q, double* M);

/* outputs */
PC_API int pc_measure(pc_model_t* m, const double* q, const double* v, double t, double* z, double* H, double* Hu,
               double* Hp);
PC_API int pc_sample(pc_model_t* m, const double* q, const double* v, double t, double* ddq, double* panels,
              double* mech);
PC_API void pc_panel_outputs(const pc_model_t* m, const double* q, double* out);
PC_API void pc_panel_jacobian(const pc_model_t* m, double* J);
PC_API void pc_panel_quat_jacobian(const pc_model_t* m, const double* q, double* J);

/* integration */
PC_API int pc_step(pc_model_t* m, double* q, double* v, double t, double h, double* quad);
PC_API int pc_step_jacobian(pc_model_t* m, double* q, double* v, double t, double h, double* F, double* Fu, double* Fp);
PC_API int pc_simulate(pc_model_t* m, double* q, double* v, double t0, double sample, double h, int per_sample,
                       int k0, int n_samples,
                double* q_hist, double* v_hist, double* a_hist, double* panels_hist, double* mech_hist,
                double* bal_hist, double* u_hist, volatile int* cancel);
PC_API int pc_predict(pc_model_t* m, double* q, double* v, double t, double h, int n_steps, int want_jac, double* z,
               double* F, double* Fu, double* Fp, double* H, double* Hu, double* Hp);

#endif
