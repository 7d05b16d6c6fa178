/*
 * postcapture FMU runtime: the plant's state, its integrator and its outputs.
 *
 * The sizes, value references, tableau, excitation profiles and defaults come from the generated
 * "pc_model_data.h"; the dynamics from the CasADi-generated functions pc_* (pc_model.c,
 * pc_model_jac.c). Nothing here depends on a particular FMI version: pc_fmi2.c wraps it.
 *
 * State x = [q (nq), v (nv)] in Pinocchio's layout (free flyer: position, quaternion x y z w, then
 * the joint angles; body twist then joint rates). Tangent coordinates (nt = 2 nv) are Pinocchio's
 * right perturbations.
 */
#ifndef PC_CORE_H
#define PC_CORE_H

#include "pc_types.h"
#include "pc_model_data.h"

#ifndef PC_MAX_NEWTON
#define PC_MAX_NEWTON 40 /* iterations per attempt */
#endif
#define PC_NEWTON_TOL2 1e-28   /* squared relative error estimate: converged (1e-14) */
#define PC_NEWTON_FLOOR2 1e-20 /* squared relative correction accepted once it stops shrinking (1e-10) */

#define PC_NT (2 * PC_NV)
#define PC_NPJ (PC_NT + PC_HAS_TARGET) /* step-Jacobian columns: tangent state, then the mass */
#if PC_STEP_JACOBIAN
#define PC_NJAC (PC_NT * PC_NT + PC_NT + PC_NZ * PC_NT + PC_NZ)
#else
#define PC_NJAC 1
#endif

enum { PC_MODE_INSTANTIATED = 0, PC_MODE_INIT = 1, PC_MODE_STEP = 2, PC_MODE_TERMINATED = 3, PC_MODE_ERROR = 4 };

/* Everything fmi2GetFMUstate saves: plain data, copied and serialised byte for byte. */
typedef struct {
    double time;
    double x[PC_NX];
    double p[PC_NP];
    double u[PC_NU];
    double xc[PC_NX];
    double reset;
    double jreq;
    double jac[PC_NJAC]; /* F (nt x nt), g (nt), H (nz x nt), h (nz), row-major */
    int jac_valid;
    int mode;
} pc_core_t;

typedef void (*pc_log_fn)(void* env, int status, const char* category, const char* message);

typedef struct {
    pc_core_t c;
    /* lazily computed outputs at the current time */
    int out_valid;
    double ddq[PC_NV];
    double xdot[PC_NX];
    double y[PC_NY];
    /* CasADi work memory */
    const double** arg;
    double** res;
    int* iw;
    double* w;
    /* integrator work */
    double Kxi[PC_STAGES][PC_NV], Kv[PC_STAGES][PC_NV];
    double Zxi[PC_STAGES][PC_NV], ZV[PC_STAGES][PC_NV], Zu[PC_STAGES][PC_NU];
    double S[PC_NV * PC_NV]; /* LU of the Newton matrix */
    int piv[PC_NV];
    double Aq[PC_NV * PC_NV], Av[PC_NV * PC_NV], dm[PC_NV]; /* d ddq / d(q tangent, v, m) */
    double J[PC_NV * PC_NJC];
    double qtmp[PC_NQ], qtmp2[PC_NQ];
    double tmp[PC_NV], tmp2[PC_NV];
#if PC_STEP_JACOBIAN
    double dK[PC_STAGES][PC_NT * PC_NPJ];
    double dZ[PC_NT * PC_NPJ];
    double R[PC_NT * PC_NPJ];
    double Fs[PC_NT * PC_NPJ];
    double Facc[PC_NT * PC_NPJ];
    double work[PC_NT * PC_NPJ];
#endif
    /* logging */
    pc_log_fn log;
    void* log_env;
} pc_inst_t;

/* CasADi-generated functions (pc_model.c, pc_model_jac.c) */
#define PC_FN(name)                                                                 \
    int name(const double** arg, double** res, int* iw, double* w, int mem);        \
    int name##_work(int* sz_arg, int* sz_res, int* sz_iw, int* sz_w);
PC_FN(pc_ddq)
PC_FN(pc_ddq_jac)
PC_FN(pc_ddq_jvp)
PC_FN(pc_integ)
PC_FN(pc_out)
PC_FN(pc_out_jvp)
PC_FN(pc_meas)
#if PC_FREE_FLYER
PC_FN(pc_dint)
#endif

int pc_setup(pc_inst_t* S);
void pc_teardown(pc_inst_t* S);
void pc_defaults(pc_inst_t* S);
void pc_inputs(const pc_inst_t* S, double t, int left, double* u);
int pc_update_outputs(pc_inst_t* S);
int pc_step(pc_inst_t* S, double t, double H, int want_jac);
int pc_directional(pc_inst_t* S, const double* dx, const double* du, double* dxdot, double* dy);
void pc_logf(pc_inst_t* S, int status, const char* category, const char* fmt, ...);
int pc_call_ddq(pc_inst_t* S, const double* q, const double* v, const double* u, double* ddq);
int pc_call_integ(pc_inst_t* S, const double* q, const double* xi, double* q1);
int pc_call_jac(pc_inst_t* S, const double* q, const double* v, const double* u, double* ddq);

/* status codes of the core (mapped to FMI status by the wrapper) */
enum { PC_OK = 0, PC_WARNING = 1, PC_DISCARD = 2, PC_ERROR = 3 };

#endif
