/*
 * postcapture plant core (internal): the layout of the constant model and of one instance's data, and
 * the functions the stage files share. Which file owns what:
 *   pc_model.c            packed arrays -> model, the tableau
 *   pc_validate.c         pc_validate: every index and size of a model, before anything runs
 *   pc_data.c             data life cycle, the scratch arena, the error buffer, parameters, settings
 *   pc_inputs.c           excitation profiles and the input map (B u)
 *   pc_passive.c          springs and dampers: forces, their partials, energy, the Newton "armature"
 *   pc_kinematics.c       joint and world placements, centre of mass, output frames, measurement, samples
 *   pc_aba.c              articulated-body algorithm and the articulated factorization of M + armature
 *   pc_rnea.c             recursive Newton-Euler inverse dynamics and its parameter partials
 *   pc_rnea_derivatives.c analytic partials of the inverse dynamics (q, v)
 *   pc_crba.c             composite-rigid-body mass matrix
 *   pc_derivatives.c      partials of the forward dynamics (force form, M^-1 columns, selected rows)
 *   pc_liegroup.c         the configuration group: integrate, difference, their tangent maps, dexpinv
 *   pc_linalg.c           small dense linear algebra (LU, 6x6 Cholesky)
 *   pc_integrator.c       Lie-group DIRK steps (Newton in force form), the truth loop
 *   pc_jacobian.c         exact step Jacobians, the measurement Jacobians, the filters' prediction
 */
#ifndef PC_INTERNAL_H
#define PC_INTERNAL_H

#include <math.h>
#include <string.h>

#include "pc_plant.h"
#include "pc_spatial.h"

/* One excitation profile on one input channel, active on [start, stop). */
typedef struct {
    int kind, channel, table, n_table;
    double start, stop, a, rise, w, phase, offset, f0, rate;
} pc_profile_t;

typedef struct {
    int parent;        /* parent joint (-1: the universe) */
    int kind;          /* -1 free flyer, 0/1/2 revolute about x/y/z */
    int iq, iv;        /* first configuration / velocity index */
    double R[9], p[3]; /* placement in the parent joint's frame */
    double pi[10];     /* nominal inertia: dynamic parameters in the joint frame */
    int axis_only;     /* revolute with an identity placement rotation: its rotation is about one axis */
} pc_joint_t;

typedef struct {
    int v[2];        /* velocity indices of the (at most two) coordinates, -1 when unused */
    double a[2];     /* coefficients: deflection a . q - rest */
    double k0, d0;   /* nominal stiffness and damping */
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

/* The constant model (never written after pc_model_create). */
struct pc_model {
    int nq, nv, nj, nu, ns, nprof, npanels, ntable, custom_b, n_arm, n_arm_v, target_joint, np, free_flyer;
    int n_root_v, n_root_q, nz;
    pc_joint_t* joints;
    pc_spring_t* springs;
    int* u_to_v;          /* nu: velocity index of each input (default input map) */
    double* B;            /* nv x nu: the input matrix (custom, or from u_to_v) */
    pc_profile_t* prof;
    double* table_t;
    double* table_v;
    pc_panel_t* panels;
    int* arm_v;           /* n_arm_v */
    int* sub_end;         /* nj: one past the last joint of each joint's subtree (depth-first numbering) */
    double r_acc[3];      /* accelerometer position in the root body frame */
    double t_L[100];      /* 10 x 10: target hub parameters (T frame) -> joint-frame parameters */
    double t_base[10];    /* the target joint's inertia without the hub */
    double* p0;           /* np: nominal parameter vector */
    int diag_springs;     /* every spring acts on one coordinate */
    pc_tableau_t tab;
    size_t arena_size;    /* doubles of scratch each data gets */
    void* block;          /* the one allocation holding the arrays above */
};

/* Joint-space factorization of M(q) + diag(armature) by the articulated-body recursion. */
typedef struct {
    double* R;    /* nj x 9: joint placements in the parent at the factorization point */
    double* p;    /* nj x 3 */
    double* U;    /* nj x 6 */
    double* Dinv; /* nj */
    double* cs;   /* nj x 2: cos, sin of the joint angles */
    double root[36]; /* Cholesky factor of the root's articulated inertia */
    int valid;
} pc_factor_t;

/* Newton policy of the implicit stages (see pc_integrator.c). */
typedef struct {
    double rtol, atol;
    int max_iter;
} pc_newton_t;

/* One instance's mutable state over a model. */
struct pc_data {
    /* parameters and what follows from them */
    double* params;       /* np */
    double* pi;           /* nj x 10: joint inertias at the current parameters */
    double* k;            /* ns: spring stiffnesses at the current scales */
    double* dmp;          /* ns: damper coefficients at the current scales */
    double* u_extra;      /* nu: added to the excitation */
    double orbit_n;       /* mean motion of the circular orbit (rad/s); 0: free space (pc_gravity.c) */
    double orbit_t;       /* the time at which the forces are evaluated (set with the inputs) */
    pc_newton_t newton;
    /* statistics */
    long n_steps, n_newton, n_factor;
    /* warm start: the previous steps' stages */
    int have_prev;        /* previous steps remembered (0, 1 or 2), all of step prev_h */
    double prev_h;
    double *prev_V, *prev_v, *prev2_V, *prev2_v;
    /* workspace of the recursions */
    double *Rl, *pl, *csl; /* joint placements in the parent, cos/sin of revolute angles (current q) */
    double *Ro, *po;       /* world placements */
    double *vj, *aj, *cj, *fj; /* nj x 6 */
    double* IA;            /* nj x 36 */
    double *Uj, *Dj, *uj;
    double* tmp_nv[8];
    double* tmp_nq[2];
    pc_factor_t fac;       /* the integrator's Newton matrix */
    pc_factor_t fac2;      /* a second factorization (derivatives) */
    double* dense;         /* nv x nv (dense Newton matrix) */
    double* dense2;        /* nv x nv (stage sensitivity matrix) */
    int* piv;
    /* scratch arena: a stack of doubles, marked and released by each call */
    double* arena;
    size_t arena_size, arena_top, arena_peak;
    void* block;
    char error[512];
};

/* The stages of one step (each nv, inputs nu). */
typedef struct {
    double* xi[PC_MAX_STAGES];
    double* V[PC_MAX_STAGES];
    double* Kxi[PC_MAX_STAGES];
    double* Kv[PC_MAX_STAGES];
    double* u[PC_MAX_STAGES];
} pc_stages_t;

/* pc_data.c */
typedef struct {
    char* base;
    size_t used;
} pc_carve_t;
void* pc_carve(pc_carve_t* c, size_t n, size_t size);
void pc_set_error(pc_data_t* d, const char* fmt, ...);
double* pc_arena_alloc(pc_data_t* d, size_t n);
#define PC_ARENA_MARK(d) ((d)->arena_top)
#define PC_ARENA_RELEASE(d, mark) ((d)->arena_top = (mark))
size_t pc_arena_need(const pc_model_t* m);
int pc_stages_alloc(const pc_model_t* m, pc_data_t* d, pc_stages_t* S);
int pc_params_problem(const pc_model_t* m, const double* p, char* err, size_t n);

/* pc_model.c, pc_validate.c */
int pc_model_error(char* err, size_t n, const char* fmt, ...);
int pc_validate(const pc_model_t* m, char* err, size_t err_size);

/* pc_inputs.c */
void pc_profile_unpack(const int* ip, const double* dp, pc_profile_t* P);
void pc_inputs_at(const pc_model_t* m, const pc_data_t* d, double t, int left, double* u);
void pc_input_force(const pc_model_t* m, const double* u, double* tau);

/* pc_passive.c */
void pc_spring_force(const pc_model_t* m, const pc_data_t* d, const double* q, const double* v, double* tau);
void pc_spring_partials(const pc_model_t* m, const pc_data_t* d, double* Cq, double* Cv);
void pc_spring_param_forces(const pc_model_t* m, const double* q, const double* v, double* Tp);
double pc_elastic_energy(const pc_model_t* m, const pc_data_t* d, const double* q);
double pc_spring_power(const pc_model_t* m, const pc_data_t* d, const double* v);
void pc_spring_armature(const pc_model_t* m, const pc_data_t* d, double hg, double* arm);
void pc_spring_dense(const pc_model_t* m, const pc_data_t* d, double hg, double* M);
void pc_force(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u, double* tau);
/* pc_gravity.c: the gravity gradient of the instance's orbit, added to tau; FM (6, or NULL) gets the field's
 * force and moment about N's origin (kinematics of q computed) */
int pc_gravity_force(const pc_model_t* m, pc_data_t* d, const double* q, double* tau, double* FM);
void pc_orbit_time(pc_data_t* d, double t);

/* pc_kinematics.c */
void pc_kinematics(const pc_model_t* m, pc_data_t* d, const double* q);
void pc_world_placements(const pc_model_t* m, pc_data_t* d);
void pc_measurement(const pc_model_t* m, const double* v, const double* ddq, double* z);

/* pc_aba.c */
int pc_factorize(const pc_model_t* m, pc_data_t* d, const double* q, const double* armature, pc_factor_t* F);
void pc_factor_solve(const pc_model_t* m, pc_data_t* d, const pc_factor_t* F, double* x);

/* pc_rnea.c */
void pc_param_forces(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double* Tp);

/* pc_crba.c */
void pc_joint_inertia_matrix(const double* pi, double* I6);
void pc_add_transformed_inertia(const double* R, const double* p, const double* Ia, double* Ip);
int pc_crba(const pc_model_t* m, pc_data_t* d, const double* q, double* M);

/* pc_derivatives.c */
int pc_force_partials(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                      double* ddq, double* Cq, double* Cv, double* Tp);
int pc_rows_from_partials(const pc_model_t* m, pc_data_t* d, const double* q, const double* Cq, const double* Cv,
                          const double* Tp, const int* rows, int nr, double* Aq, double* Av, double* Au, double* Ap);
int pc_derivative_rows(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, const double* u,
                       const int* rows, int nr, double* ddq, double* Aq, double* Av, double* Au, double* Ap);

/* pc_liegroup.c */
void pc_dexpinv_apply(const double* xi, const double* V, double* out);
void pc_dexpinv_mats(const double* xi, const double* V, double* G, double* Gx);
void pc_dintegrate_root(const double* xi, double* J0, double* Jr);

/* pc_linalg.c */
int pc_lu_factor(double* A, int* piv, int n);
void pc_lu_solve(const double* LU, const int* piv, int n, double* B, int m, int ld);
int pc_chol6(double* A);
void pc_chol6_solve(const double* L, double* x);

/* pc_integrator.c */
int pc_step_internal(const pc_model_t* m, pc_data_t* d, double* q, double* v, double t, double h, pc_stages_t* S,
                     double* xi_end, int warm);

#endif
