/*
 * postcapture plant core: the public interface. The flexible multibody plant, its Lie-group
 * integrators, step Jacobians and outputs, in plain C99 (libm only). The same sources run behind the
 * Python package (loaded with ctypes from a per-machine build) and inside exported FMUs.
 *
 * Two objects, as in MuJoCo (mjModel / mjData) and Pinocchio (Model / Data):
 *   - pc_model_t: the constant, validated model: the joint tree, springs, input map, excitation
 *     profiles, output frames and the Butcher tableau. Created once from the packed arrays of
 *     postcapture.dynamics.packing (layout in pc_model.c), checked by pc_validate, never changed.
 *     Any number of data may run over one model, in threads.
 *   - pc_data_t: one instance's mutable state: the parameter vector and what follows from it, the
 *     input offset, the Newton settings, the warm start, the statistics, an arena from which every
 *     call takes its scratch memory (nothing is allocated after pc_data_create) and an error buffer.
 *
 * Conventions (Pinocchio's): twists and wrenches are (linear, angular); a placement (R, p) of a child
 * frame in its parent maps child coordinates to parent ones; the root's configuration is
 * (position, quaternion x y z w) and its velocity the body twist; tangent perturbations of the
 * configuration are right perturbations. Matrices are row-major. Every int-returning call returns a
 * PC_* status; on failure pc_error_message(d) says why.
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
enum {
    PC_OK = 0, PC_ERR_NEWTON = 1, PC_ERR_NONFINITE = 2, PC_ERR_SINGULAR = 3, PC_ERR_ARG = 4, PC_ERR_MEMORY = 5,
    PC_ERR_MODEL = 6
};

#define PC_MAX_STAGES 8

typedef struct pc_model pc_model_t;
typedef struct pc_data pc_data_t;

/* library */
PC_API int pc_layout_version(void);
PC_API const char* pc_build_id(void);

/* model: created from the packed arrays and a lower-triangular tableau (s stages, A s x s, b, c);
 * NULL on failure with the reason written to err (err_size bytes). */
PC_API pc_model_t* pc_model_create(const int* ib, const double* db, size_t n_ib, size_t n_db, int s, const double* A,
                                   const double* b, const double* c, char* err, size_t err_size);
PC_API void pc_model_destroy(pc_model_t* m);
PC_API int pc_sizes(const pc_model_t* m, int* out); /* nq, nv, nu, np, nz, npanels, nj, stages */
PC_API int pc_nominal_params(const pc_model_t* m, double* p);

/* data: one instance over a model, at the model's nominal parameters; NULL when out of memory */
PC_API pc_data_t* pc_data_create(const pc_model_t* m);
PC_API void pc_data_destroy(pc_data_t* d);
PC_API int pc_data_copy(const pc_model_t* m, pc_data_t* dst, const pc_data_t* src); /* settings, not warm start */
PC_API const char* pc_error_message(const pc_data_t* d);
PC_API int pc_set_params(const pc_model_t* m, pc_data_t* d, const double* p);
PC_API int pc_get_params(const pc_model_t* m, const pc_data_t* d, double* p);
PC_API int pc_set_input_offset(const pc_model_t* m, pc_data_t* d, const double* u_extra);
/* a circular orbit of mean motion n (rad/s; 0: free space) whose gravity gradient acts on every body
 * (pc_gravity.c: N is the orbit's local-vertical local-horizontal frame at t = 0) */
PC_API int pc_set_orbit(const pc_model_t* m, pc_data_t* d, double mean_motion);
PC_API int pc_set_newton(pc_data_t* d, double rtol, double atol, int max_iter);
PC_API void pc_stats(const pc_data_t* d, long* out); /* steps, Newton iterations, factorizations, arena peak */
PC_API void pc_reset_stats(pc_data_t* d);

/* dynamics */
PC_API int pc_inputs(const pc_model_t* m, const pc_data_t* d, double t, int left, double* u);
/* The excitation without a model: nprof profiles and their tables packed as in the model arrays (ints
 * kind, channel, table offset, table length; doubles start, stop, a, rise, w, phase, offset, f0, rate),
 * summed per channel at n_times times t into u_out (n_times x nu, row-major); left: left limits. */
PC_API int pc_inputs_eval(int nprof, const int* prof_i, const double* prof_d, int ntable, const double* table_t,
                          const double* table_v, int nu, int n_times, const double* t, int left, double* u_out);
PC_API int pc_aba(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* tau, double* ddq);
PC_API int pc_rnea(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* a, double* tau);
PC_API int pc_rnea_derivatives(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* a,
                               double* dq, double* dv);
PC_API int pc_accel(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u, double* ddq);
PC_API int pc_derivatives(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                          double* ddq, double* Aq, double* Av, double* Au, double* Ap);
PC_API int pc_mass_matrix(const pc_model_t* m, pc_data_t* d, const double* q, double* M);
PC_API int pc_center_of_mass(const pc_model_t* m, pc_data_t* d, const double* q, double* com);

/* the configuration group: q1 = q (+) dq and dq = q1 (-) q0 (with a model, or by sizes alone) */
PC_API int pc_integrate(const pc_model_t* m, const double* q, const double* dq, double* q1);
PC_API int pc_difference(const pc_model_t* m, const double* q0, const double* q1, double* dq);
PC_API int pc_lie_integrate(int nq, int nv, int free_flyer, const double* q, const double* dq, double* q1);
PC_API int pc_lie_difference(int nq, int nv, int free_flyer, const double* q0, const double* q1, double* dq);

/* outputs */
PC_API int pc_measure(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double* z,
                      double* H, double* Hu, double* Hp);
PC_API int pc_sample(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double* ddq,
                     double* panels, double* mech);
PC_API int pc_panel_outputs(const pc_model_t* m, pc_data_t* d, const double* q, double* out);
PC_API int pc_panel_jacobian(const pc_model_t* m, pc_data_t* d, const double* q, double* J);
PC_API int pc_panel_quat_jacobian(const pc_model_t* m, pc_data_t* d, const double* q, double* J);

/* integration */
PC_API int pc_step(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, double* quad);
PC_API int pc_step_jacobian(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, double* F,
                            double* Fu, double* Fp);
PC_API int pc_simulate(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t0, double sample, double h,
                       int per_sample, int k0, int n_samples, double* q_hist, double* v_hist, double* a_hist,
                       double* panels_hist, double* mech_hist, double* bal_hist, double* u_hist, volatile int* cancel);
PC_API int pc_predict(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, int n_steps,
                      int want_jac, double* z, double* F, double* Fu, double* Fp, double* H, double* Hu, double* Hp);

#endif
