/*
 * postcapture FMU: the exported plant's instance, shared by the FMI 2.0 and 3.0 wrappers (see pc_fmu.h).
 *
 * The plant is the core of postcapture.dynamics (dynamics/csrc, compiled into this library with the
 * model's packed arrays from the generated pc_fmu_data.h): the same integrator, Newton policy, warm
 * start, step rule, outputs and Jacobians as the native process model, in the filters' orbit (the
 * gravity gradient of PC_ORBIT_N when the scenario's filters model it; free space otherwise).
 *
 * Variables (value-reference blocks of pc_fmu_data.h): the state x = [q, v] (outputs), its ambient
 * derivative (locals), the named outputs, the parameter vector p (inputs held constant over a step, so
 * that their partials are standard directional derivatives), the forces and torques added to the
 * embedded excitation (inputs), the state correction x_corr and its reset flag, the Jacobian request,
 * and on request the exact Jacobians of the last step F, G, H, Hp with the flag jacobian_valid (1 when
 * they describe the last step; 0, and the Jacobians 0, otherwise).
 *
 * A communication step H is taken as n equal internal steps of H / n, n the smallest count for which
 * H / n <= PC_STEP; a whole multiple of PC_STEP (to 1e-9) is taken in steps of exactly PC_STEP, as the
 * native process model takes a filter step.
 *
 * The sampled sensors (outputs gyro_mean_*, accel_mean_*; noise-free, perfect instruments) are the native
 * sensors' definitions (studies/sensing.py, estimation/increments.py) over the last step [t0, t1] flown, by
 * the engine's own functions (pc_increments.c): the mean rate box_minus(q1, q0) / (t1 - t0) and the mean
 * specific force (Exp(phi) u1 - u0) / (t1 - t0) at the accelerometer's point PC_R_ACC (u = v + w x r, body
 * components, B at t0), less the mean of the tidal field of the orbit the plant flies (PC_ORBIT_N; none in
 * free space). A step started from x_corr (reset) starts from it. Before the first step they are the
 * instantaneous values: the body rate and the point's acceleration less the tidal field now.
 *
 * PC_LEAD > 0 runs the plant that far ahead of the master's clock: leaving initialisation flies
 * [t0, t0 + PC_LEAD] (the sampled sensors then hold its means), and a step from the master's t flies
 * [t + PC_LEAD, t + PC_LEAD + H]; the excitation and the orbit's field follow the plant's time, the last
 * successful time (fmi2GetRealStatus) and FMI 3.0's independent variable time the master's.
 *
 * Checks: every real set must be finite and within PC_MAX_ABS (parameters at least their bound); a
 * communication step finite and in (0, PC_MAX_COMM_STEP]; a corrected state's quaternion within
 * PC_QUAT_TOL of unit norm (then normalised); so must be the quaternion of the state leaving
 * initialisation and of any state restored or deserialised (whose entries must all be finite and whose
 * parameters the core must accept). A refused call
 * returns Error with a logged message naming the variable and keeps the state; a failed step puts the
 * instance in the error state (only getters, the FMU-state calls, reset, terminate and free are then
 * accepted).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pc_filter.h"
#include "pc_fmu.h"

#define NQ PC_NQ
#define NV PC_NV
#define NX PC_FMU_NX
#define NT PC_FMU_NT
#define NP PC_NP
#define NJAC PC_FMU_NJAC
#define PC_MAX_ABS 1e15   /* largest magnitude of any real set */
#define PC_QUAT_TOL 1e-6  /* |norm(quaternion) - 1| accepted before normalisation */
#define PC_STATE_MAGIC 0x53464350u /* "PCFS" */
#define PC_STATE_VERSION 4u
#define PC_HEADER_SIZE (4 * sizeof(uint32_t))

/* ------------------------------------------------------------------------------------ messages */
static void say(pc_fmu_t* F, int status, const char* category, const char* fmt, ...) {
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (status == PC_FMU_ERROR) snprintf(F->last_error, sizeof F->last_error, "%s", buf);
    if (!F->log || (status == PC_FMU_OK && !F->logging)) return;
    F->log(F->env, F->name, status, category, buf);
}

int pc_fmu_fail(pc_fmu_t* F, const char* function, const char* fmt, ...) {
    char buf[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    say(F, PC_FMU_ERROR, "logStatusError", "%s: %s", function, buf);
    return PC_FMU_ERROR;
}

int pc_fmu_in_error(pc_fmu_t* F, const char* function) {
    char buf[1024];
    if (F->c.mode != PC_MODE_ERROR) return PC_FMU_OK;
    if (F->log) {
        snprintf(buf, sizeof buf, "%s: the instance is in the error state after: %s (restore an FMU state or reset it)",
                 function, F->last_error);
        F->log(F->env, F->name, PC_FMU_ERROR, "logStatusError", buf);
    }
    return PC_FMU_ERROR;
}

static const char* vr_name(unsigned r) { return r < PC_NVARS ? PC_VAR_NAMES[r] : "?"; }

static uint32_t guid_hash(void) {
    const char* s = PC_GUID;
    uint32_t h = 2166136261u;
    while (*s) { h ^= (uint8_t)*s++; h *= 16777619u; }
    return h;
}

/* ------------------------------------------------------------------------------------ lifecycle */
void pc_fmu_defaults(pc_fmu_t* F) {
    int i;
    memset(&F->c, 0, sizeof F->c);
    memcpy(F->c.x, PC_X0, sizeof F->c.x);
    memcpy(F->c.xc, PC_X0, sizeof F->c.xc);
    for (i = 0; i < NP; i++) F->c.p[i] = PC_P0[i];
    F->out_valid = 0;
    F->c.mode = PC_MODE_INSTANTIATED;
}

pc_fmu_t* pc_fmu_new(const char* function, const char* name, pc_fmu_logger_t log, void* env, int logging) {
    pc_fmu_t* F;
    char err[512] = "", buf[700];
    F = (pc_fmu_t*)calloc(1, sizeof(pc_fmu_t));
    if (!F) return NULL;
    F->log = log;
    F->env = env;
    F->name = (char*)malloc(strlen(name) + 1);
    F->m = pc_model_create(PC_IB, PC_DB, sizeof PC_IB / sizeof PC_IB[0], sizeof PC_DB / sizeof PC_DB[0], PC_STAGES,
                           &PC_TAB_A[0][0], PC_TAB_B, PC_TAB_C, err, sizeof err);
    F->d = F->m ? pc_data_create(F->m) : NULL;
    if (F->d && PC_ORBIT_N > 0.0 && pc_set_orbit(F->m, F->d, PC_ORBIT_N)) {
        snprintf(err, sizeof err, "the orbit was refused: %s", pc_error_message(F->d));
        pc_data_destroy(F->d);
        F->d = NULL;
    }
    if (!F->name || !F->m || !F->d) {
        if (log) {
            snprintf(buf, sizeof buf, "%s: the plant could not be created: %s", function,
                     err[0] ? err : "out of memory");
            log(env, name, PC_FMU_ERROR, "logStatusError", buf);
        }
        pc_fmu_free(F);
        return NULL;
    }
    strcpy(F->name, name);
    F->logging = logging;
    pc_fmu_defaults(F);
    return F;
}

void pc_fmu_free(pc_fmu_t* F) {
    if (!F) return;
    pc_data_destroy(F->d);
    pc_model_destroy(F->m);
    free(F->name);
    free(F);
}

int pc_fmu_start(pc_fmu_t* F, const char* function, double start_time) {
    if (F->c.mode != PC_MODE_INSTANTIATED) return pc_fmu_fail(F, function, "only allowed after instantiation");
    if (!(fabs(start_time) < PC_MAX_ABS)) return pc_fmu_fail(F, function, "startTime %.17g is not a finite time", start_time);
    F->c.time = F->c.last_ok_time = start_time;
    return PC_FMU_OK;
}

/* |q| of the state's attitude quaternion (x[3..6]); NaN when an entry is not finite */
static double quat_norm(const double* x) {
    double s = 0.0;
    int i;
    for (i = 3; i < 7; i++) s += x[i] * x[i];
    return sqrt(s);
}

static int fly(pc_fmu_t* F, const char* function, double t, double H, double t_master);

/* the state set during initialisation is checked (not normalised: its directional derivatives are those
 * of the ambient entries a master set); with PC_LEAD the plant then flies [t0, t0 + PC_LEAD] */
int pc_fmu_exit_init(pc_fmu_t* F, const char* function) {
    double nq = quat_norm(F->c.x);
    if (F->c.mode != PC_MODE_INIT) return pc_fmu_fail(F, function, "only allowed in initialisation mode");
    if (!(fabs(nq - 1.0) <= PC_QUAT_TOL))
        return pc_fmu_fail(F, function, "the initial state's attitude quaternion q[4..7] has norm %.17g: expected 1 within %g",
                           nq, PC_QUAT_TOL);
    F->c.mode = PC_MODE_STEP;
    F->out_valid = 0;
    if (PC_LEAD > 0.0) return fly(F, function, F->c.time, PC_LEAD, F->c.time); /* ahead of the master */
    return PC_FMU_OK;
}

static void push_settings(pc_fmu_t* F) {
    if (NP) pc_set_params(F->m, F->d, F->c.p);
    pc_set_input_offset(F->m, F->d, F->c.u);
}

/* ------------------------------------------------------------------------------------ outputs */
/* rotation matrix of the (x, y, z, w) quaternion a, Eigen's formula */
static void quat_matrix(const double* a, double* R) {
    double x = a[0], y = a[1], z = a[2], w = a[3];
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - w * z); R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z); R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y); R[7] = 2 * (y * z + w * x); R[8] = 1 - 2 * (x * x + y * y);
}

/* scalar-first q_BN of a configuration's quaternion (q[3..6] = x, y, z, w) */
static void q_scalar_first(const double* q, double* out) {
    out[0] = q[6]; out[1] = q[3]; out[2] = q[4]; out[3] = q[5];
}

/* the tidal field of the plant's orbit at the accelerometer's point now, in B (0 in free space) */
static void tidal_now(const double* q, double t, double* g) {
    double qs[4];
    q_scalar_first(q, qs);
    pc_tidal_mean(qs, q, qs, q, PC_R_ACC, PC_ORBIT_N, t, t, g);
}

/* the sampled sensors over a step from x0 at t0 to x1 at t1: mean rate, then mean specific force */
static void sensed_means(const double* x0, const double* x1, double t0, double t1, double* out) {
    double q0[4], q1[4], phi[3], g[3], dt = t1 - t0;
    const double* v0 = x0 + NQ;
    const double* v1 = x1 + NQ;
    int i;
    q_scalar_first(x0, q0);
    q_scalar_first(x1, q1);
    pc_mean_rate(q0, q1, dt, out, NULL, NULL, phi);
    pc_mean_specific_force(phi, v0, v0 + 3, v1, v1 + 3, PC_R_ACC, dt, out + 3, NULL);
    pc_tidal_mean(q0, x0, q1, x1, PC_R_ACC, PC_ORBIT_N, t0, t1, g);
    for (i = 0; i < 3; i++) out[3 + i] -= g[i];
}

/* the sampled sensors (6 outputs): the last step's means, or before any step the instantaneous values */
static void sampled_sensors(const pc_fmu_t* F, const double* q, const double* v, const double* mech, double* y) {
    int i;
    if (F->c.sensed) {
        for (i = 0; i < 6; i++) y[i] = F->c.sens[i];
    } else {
        double g[3];
        tidal_now(q, F->c.time, g);
        for (i = 0; i < 3; i++) y[i] = v[3 + i];
        for (i = 0; i < 3; i++) y[3 + i] = mech[11 + i] - g[i];
    }
}

/* ambient state derivative: dp/dt = R v, dquat/dt = quat (w, 0) / 2, de/dt = v_e, dv/dt = ddq */
static void state_derivative(pc_fmu_t* F, const double* q, const double* v) {
    const double* a = q + 3;
    const double* w = v + 3;
    double R[9];
    int i;
    quat_matrix(a, R);
    for (i = 0; i < 3; i++) F->xdot[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
    F->xdot[3] = 0.5 * (a[3] * w[0] + a[1] * w[2] - a[2] * w[1]);
    F->xdot[4] = 0.5 * (a[3] * w[1] - a[0] * w[2] + a[2] * w[0]);
    F->xdot[5] = 0.5 * (a[3] * w[2] + a[0] * w[1] - a[1] * w[0]);
    F->xdot[6] = 0.5 * (-a[0] * w[0] - a[1] * w[1] - a[2] * w[2]);
    for (i = 7; i < NQ; i++) F->xdot[i] = v[i - 1];
    for (i = 0; i < NV; i++) F->xdot[NQ + i] = F->ddq[i];
}

static int update_outputs(pc_fmu_t* F) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    double mech[11 + PC_NZ], panels[4 * PC_NPANELS + 1];
    int i, k = 0, off = NQ - NV;
    if (F->out_valid) return 0;
    push_settings(F);
    if (pc_sample(F->m, F->d, q, v, F->c.time, F->ddq, panels, mech)) return 1;
    /* y: q_BN (w >= 0) 4, omega 3, r 3, accel 3, arm q, dq, ddq, panels (tip 3, torsion) */
    {
        double s = q[6] < 0.0 ? -1.0 : 1.0;
        F->y[k++] = s * q[6]; F->y[k++] = s * q[3]; F->y[k++] = s * q[4]; F->y[k++] = s * q[5];
    }
    for (i = 0; i < 3; i++) F->y[k++] = v[3 + i];
    for (i = 0; i < 3; i++) F->y[k++] = q[i];
    for (i = 0; i < 3; i++) F->y[k++] = mech[11 + i];
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? q[PC_ARM_V[i] + off] : 0.0;
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? v[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < PC_NARM; i++) F->y[k++] = i < PC_NARM_V ? F->ddq[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < 4 * PC_NPANELS; i++) F->y[k++] = panels[i];
    sampled_sensors(F, q, v, mech, F->y + k);
    state_derivative(F, q, v);
    F->out_valid = 1;
    return 0;
}

/* ------------------------------------------------------------------------------------ values */
int pc_fmu_get(pc_fmu_t* F, const char* function, const unsigned* vr, size_t n, double* value) {
    size_t k;
    for (k = 0; k < n; k++) {
        unsigned r = vr[k];
        if (r < PC_VR_DX) value[k] = F->c.x[r - PC_VR_X];
        else if (r < PC_VR_P) {
            if (update_outputs(F)) return pc_fmu_fail(F, function, "output evaluation failed: %s", pc_error_message(F->d));
            value[k] = r < PC_VR_Y ? F->xdot[r - PC_VR_DX] : F->y[r - PC_VR_Y];
        } else if (r < PC_VR_U) value[k] = F->c.p[r - PC_VR_P];
        else if (r < PC_VR_XC) value[k] = F->c.u[r - PC_VR_U];
        else if (r < PC_VR_RESET) value[k] = F->c.xc[r - PC_VR_XC];
        else if (r == PC_VR_RESET) value[k] = F->c.reset;
        else if (r == PC_VR_JREQ) value[k] = F->c.jreq;
#if PC_STEP_JACOBIAN
        else if (r >= PC_VR_JAC && r < PC_VR_JAC + NJAC) value[k] = F->c.jac[r - PC_VR_JAC];
        else if (r == PC_VR_JVALID) value[k] = F->c.jac_valid;
#endif
#ifdef PC_VR_TIME
        else if (r == PC_VR_TIME) value[k] = F->c.last_ok_time; /* the master's time (the plant's less PC_LEAD) */
#endif
        else return pc_fmu_fail(F, function, "unknown value reference %u", r);
    }
    return PC_FMU_OK;
}

/* one value into the next state (all or nothing: the caller commits only if every one is valid) */
static int set_one(pc_fmu_t* F, const char* function, pc_fmu_state_t* next, unsigned r, double x) {
    if (!(fabs(x) <= PC_MAX_ABS))
        return pc_fmu_fail(F, function, "%s = %.17g: expected a finite number of magnitude at most %g", vr_name(r), x,
                           PC_MAX_ABS);
    if (r < PC_VR_DX) {
        if (F->c.mode != PC_MODE_INSTANTIATED && F->c.mode != PC_MODE_INIT)
            return pc_fmu_fail(F, function,
                               "%s: a state can only be set before the end of initialisation; correct it with the "
                               "x_corr inputs and reset = 1 (applied at the start of the next step)", vr_name(r));
        next->x[r - PC_VR_X] = x;
        next->xc[r - PC_VR_X] = x;
    } else if (r >= PC_VR_P && r < PC_VR_U) {
        int i = (int)(r - PC_VR_P);
        if (!(x >= PC_P_MIN[i]))
            return pc_fmu_fail(F, function, "%s = %.17g: expected at least %.17g", vr_name(r), x, PC_P_MIN[i]);
        next->p[i] = x;
    } else if (r >= PC_VR_U && r < PC_VR_XC) next->u[r - PC_VR_U] = x;
    else if (r >= PC_VR_XC && r < PC_VR_RESET) next->xc[r - PC_VR_XC] = x;
    else if (r == PC_VR_RESET) next->reset = x;
    else if (r == PC_VR_JREQ) next->jreq = x;
    else return pc_fmu_fail(F, function, "%s is not settable (an output or an unknown value reference)", vr_name(r));
    return PC_FMU_OK;
}

int pc_fmu_set(pc_fmu_t* F, const char* function, const unsigned* vr, size_t n, const double* value) {
    pc_fmu_state_t* next = &F->next; /* all or nothing: committed if every value is valid */
    size_t k;
    if (pc_fmu_in_error(F, function)) return PC_FMU_ERROR;
    if (F->c.mode == PC_MODE_TERMINATED) return pc_fmu_fail(F, function, "the instance is terminated");
    *next = F->c;
    for (k = 0; k < n; k++)
        if (set_one(F, function, next, vr[k], value[k]) != PC_FMU_OK) return PC_FMU_ERROR;
    if (NP && memcmp(next->p, F->c.p, sizeof next->p) != 0 && pc_set_params(F->m, F->d, next->p)) {
        pc_set_params(F->m, F->d, F->c.p);
        return pc_fmu_fail(F, function, "parameters refused: %s", pc_error_message(F->d));
    }
    F->c = *next;
    F->out_valid = 0;
    return PC_FMU_OK;
}

/* ------------------------------------------------------------------------------------ derivatives */
#if PC_DIRECTIONAL
/* d(ambient state derivative) for dx (ambient) and the acceleration change dd */
static void directional_xdot(const double* q, const double* v, const double* dx, const double* dd, double* dxdot) {
    const double* dv = dx + NQ;
    const double* a = q + 3;
    const double* da = dx + 3;
    const double* w = v + 3;
    const double* dw = dv + 3;
    double x = a[0], y = a[1], z = a[2], ww = a[3], dxq = da[0], dyq = da[1], dzq = da[2], dwq = da[3];
    double R[9], dR[9];
    int i;
    quat_matrix(a, R);
    dR[0] = -4 * (y * dyq + z * dzq); dR[1] = 2 * (x * dyq + y * dxq - ww * dzq - z * dwq);
    dR[2] = 2 * (x * dzq + z * dxq + ww * dyq + y * dwq); dR[3] = 2 * (x * dyq + y * dxq + ww * dzq + z * dwq);
    dR[4] = -4 * (x * dxq + z * dzq); dR[5] = 2 * (y * dzq + z * dyq - ww * dxq - x * dwq);
    dR[6] = 2 * (x * dzq + z * dxq - ww * dyq - y * dwq); dR[7] = 2 * (y * dzq + z * dyq + ww * dxq + x * dwq);
    dR[8] = -4 * (x * dxq + y * dyq);
    for (i = 0; i < 3; i++)
        dxdot[i] = dR[3 * i] * v[0] + dR[3 * i + 1] * v[1] + dR[3 * i + 2] * v[2] + R[3 * i] * dv[0] +
                   R[3 * i + 1] * dv[1] + R[3 * i + 2] * dv[2];
    dxdot[3] = 0.5 * (da[3] * w[0] + da[1] * w[2] - da[2] * w[1] + a[3] * dw[0] + a[1] * dw[2] - a[2] * dw[1]);
    dxdot[4] = 0.5 * (da[3] * w[1] - da[0] * w[2] + da[2] * w[0] + a[3] * dw[1] - a[0] * dw[2] + a[2] * dw[0]);
    dxdot[5] = 0.5 * (da[3] * w[2] + da[0] * w[1] - da[1] * w[0] + a[3] * dw[2] + a[0] * dw[1] - a[1] * dw[0]);
    dxdot[6] = 0.5 * (-da[0] * w[0] - da[1] * w[1] - da[2] * w[2] - a[0] * dw[0] - a[1] * dw[1] - a[2] * dw[2]);
    for (i = 7; i < NQ; i++) dxdot[i] = dv[i - 1];
    for (i = 0; i < NV; i++) dxdot[NQ + i] = dd[i];
}

/* d(accel_B) = d(ddq[0:3] + w x v + dw x r + w x (w x r)) */
static void directional_accel(const double* v, const double* dv, const double* dd, double* out) {
    const double* w = v + 3;
    const double* dw = dv + 3;
    const double* ddw = dd + 3;
    const double* r = PC_R_ACC;
    double a1[3], a2[3], a3[3], wr[3], dwr[3], t1[3], t2[3];
    int i;
#define CROSS(a_, b_, o_) do { o_[0] = a_[1] * b_[2] - a_[2] * b_[1]; o_[1] = a_[2] * b_[0] - a_[0] * b_[2]; o_[2] = a_[0] * b_[1] - a_[1] * b_[0]; } while (0)
    CROSS(dw, v, a1); CROSS(w, dv, a2); CROSS(ddw, r, a3);
    CROSS(w, r, wr); CROSS(dw, r, dwr); CROSS(dw, wr, t1); CROSS(w, dwr, t2);
#undef CROSS
    for (i = 0; i < 3; i++) out[i] = dd[i] + a1[i] + a2[i] + a3[i] + t1[i] + t2[i];
}

/* d(named outputs), in update_outputs' order */
static int directional_outputs(pc_fmu_t* F, const double* dx, const double* dd, double* dy) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    const double* dv = dx + NQ;
    double Jp[4 * PC_NPANELS * NV + 1], Jq[16 * PC_NPANELS + 1], s = q[6] < 0.0 ? -1.0 : 1.0;
    int i, j, k = 0, off = NQ - NV;
    dy[k++] = s * dx[6]; dy[k++] = s * dx[3]; dy[k++] = s * dx[4]; dy[k++] = s * dx[5];
    for (i = 0; i < 3; i++) dy[k++] = dv[3 + i];
    for (i = 0; i < 3; i++) dy[k++] = dx[i];
    directional_accel(v, dv, dd, dy + k);
    k += 3;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dx[PC_ARM_V[i] + off] : 0.0;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dv[PC_ARM_V[i]] : 0.0;
    for (i = 0; i < PC_NARM; i++) dy[k++] = i < PC_NARM_V ? dd[PC_ARM_V[i]] : 0.0;
    if (pc_panel_jacobian(F->m, F->d, q, Jp) || pc_panel_quat_jacobian(F->m, F->d, q, Jq)) return 1;
    for (i = 0; i < 4 * PC_NPANELS; i++) {
        double t = 0.0;
        for (j = 6; j < NV; j++) t += Jp[i * NV + j] * dx[j + off];
        for (j = 0; j < 4; j++) t += Jq[i * 4 + j] * dx[3 + j];
        dy[k++] = t;
    }
    /* the sampled sensors: after a step fixed (no known moves them); before, those of the body rate and of
     * the acceleration (dy[10..12]; the tidal field's own partials left out, as the gravity gradient's) */
    for (i = 0; i < 3; i++) dy[k++] = F->c.sensed ? 0.0 : dv[3 + i];
    for (i = 0; i < 3; i++) dy[k++] = F->c.sensed ? 0.0 : dy[10 + i];
    return 0;
}

/* Continuous partials of the ambient state derivative and of the named outputs for an ambient state
 * direction dx, an input direction du and a parameter direction dp: the core's partials, exact in free
 * space. In an orbit (PC_ORBIT_N > 0) they leave out the gravity gradient's own partials (of order n^2: on
 * Envisat's rigid plant 1e-6 to 1e-5 1/s^2 per m or rad of the root's pose, which they give as zero), as
 * the native process model's Jacobians do; the model description lists the pose all the same, since the
 * accelerations depend on it. update_outputs (pc_sample) sets the field's time to the current one. */
static int directional(pc_fmu_t* F, const double* dx, const double* du, const double* dp, double* dxdot, double* dy) {
    const double* q = F->c.x;
    const double* v = F->c.x + NQ;
    const double* dv = dx + NQ;
    double u[PC_NU], dd[NV];
    double *Aq = F->A, *Av = Aq + NV * NV, *Au = Av + NV * NV, *Ap = Au + NV * PC_NU;
    int i, j, off = NQ - NV, err;
    F->out_valid = 0;
    err = update_outputs(F);
    if (!err) err = pc_inputs(F->m, F->d, F->c.time, 0, u) || pc_derivatives(F->m, F->d, q, v, u, NULL, Aq, Av, Au,
                                                                               NP ? Ap : NULL);
    if (err) return 1;
    for (i = 0; i < NV; i++) {
        double s = 0.0;
        for (j = 6; j < NV; j++) s += Aq[i * NV + j] * dx[j + off]; /* the root's columns are zero (above) */
        for (j = 0; j < NV; j++) s += Av[i * NV + j] * dv[j];
        for (j = 0; j < PC_NU; j++) s += Au[i * PC_NU + j] * du[j];
        for (j = 0; j < NP; j++) s += Ap[i * NP + j] * dp[j];
        dd[i] = s;
    }
    directional_xdot(q, v, dx, dd, dxdot);
    return directional_outputs(F, dx, dd, dy);
}
#endif

int pc_fmu_directional(pc_fmu_t* F, const char* function, const unsigned* unknown, size_t n_unknown,
                       const unsigned* known, size_t n_known, const double* seed, double* out) {
#if PC_DIRECTIONAL
    double dx[NX], du[PC_NU], dp[PC_FMU_NP1], dxdot[NX], dy[PC_NY];
    size_t k;
    if (pc_fmu_in_error(F, function)) return PC_FMU_ERROR;
    memset(dx, 0, sizeof dx);
    memset(du, 0, sizeof du);
    memset(dp, 0, sizeof dp);
    for (k = 0; k < n_known; k++) {
        unsigned r = known[k];
        if (!(fabs(seed[k]) <= PC_MAX_ABS)) return pc_fmu_fail(F, function, "seed of %s is not finite", vr_name(r));
        if (r < PC_VR_DX) dx[r - PC_VR_X] += seed[k];
        else if (r >= PC_VR_P && r < PC_VR_U) dp[r - PC_VR_P] += seed[k];
        else if (r >= PC_VR_U && r < PC_VR_XC) du[r - PC_VR_U] += seed[k];
        else
            return pc_fmu_fail(F, function, "%s: a known must be a state or a continuous input (parameter, force, "
                               "torque, joint torque)", vr_name(r));
    }
    if (directional(F, dx, du, dp, dxdot, dy))
        return pc_fmu_fail(F, function, "evaluation failed: %s", pc_error_message(F->d));
    for (k = 0; k < n_unknown; k++) {
        unsigned r = unknown[k];
        if (r < PC_VR_DX) out[k] = dx[r - PC_VR_X];
        else if (r < PC_VR_Y) out[k] = dxdot[r - PC_VR_DX];
        else if (r < PC_VR_P) out[k] = dy[r - PC_VR_Y];
#if PC_STEP_JACOBIAN
        else if ((r >= PC_VR_JAC && r < PC_VR_JAC + NJAC) || r == PC_VR_JVALID) out[k] = 0.0;
#endif
        else return pc_fmu_fail(F, function, "%s: an unknown must be a state derivative or an output", vr_name(r));
    }
    return PC_FMU_OK;
#else
    (void)unknown; (void)n_unknown; (void)known; (void)n_known; (void)seed; (void)out;
    return pc_fmu_fail(F, function, "this FMU was exported without directional derivatives");
#endif
}

/* ------------------------------------------------------------------------------------ the step */
/* n internal steps of h for a communication step H: a whole multiple of PC_STEP takes PC_STEP itself
 * (as the native process model), any other H the fewest equal steps no longer than PC_STEP */
static long internal_steps(double H, double* h) {
    long n = (long)floor(H / PC_STEP + 0.5);
    if (n >= 1 && fabs(n * PC_STEP - H) <= 1e-9 * H) {
        *h = PC_STEP;
        return n;
    }
    n = (long)ceil(H / PC_STEP);
    if (n < 1) n = 1;
    *h = H / (double)n;
    return n;
}

static int check_step(pc_fmu_t* F, const char* function, double t, double H) {
    if (pc_fmu_in_error(F, function)) return PC_FMU_ERROR;
    if (F->c.mode != PC_MODE_STEP) return pc_fmu_fail(F, function, "not in step mode (leave initialisation first)");
    if (!(H > 0.0) || !(H <= PC_MAX_COMM_STEP))
        return pc_fmu_fail(F, function, "communicationStepSize = %.17g: expected a finite step in (0, %g] s", H,
                           (double)PC_MAX_COMM_STEP);
    if (!(fabs(t) < PC_MAX_ABS)) return pc_fmu_fail(F, function, "currentCommunicationPoint = %.17g is not finite", t);
    return PC_FMU_OK;
}

/* the state the step starts from: the current one, or x_corr (its quaternion checked and normalised) */
static int start_state(pc_fmu_t* F, const char* function, double* x) {
    double nq;
    int i;
    memcpy(x, F->c.x, sizeof(double) * NX);
    if (!(F->c.reset > 0.5)) return PC_FMU_OK;
    nq = quat_norm(F->c.xc);
    if (!(fabs(nq - 1.0) <= PC_QUAT_TOL))
        return pc_fmu_fail(F, function, "x_corr[4..7] (the attitude quaternion) has norm %.17g: expected 1 within %g",
                           nq, PC_QUAT_TOL);
    memcpy(x, F->c.xc, sizeof(double) * NX);
    for (i = 3; i < 7; i++) x[i] /= nq;
    return PC_FMU_OK;
}

/* n internal steps of h from x at t (into F->scratch the Jacobians when requested); 1 on failure */
static int advance(pc_fmu_t* F, double* x, double t, double h, long n, int want_jac) {
    double z[PC_NZ];
#if PC_STEP_JACOBIAN
    if (want_jac) {
        double* Fx = F->scratch;
        double* G = Fx + NT * NT;
        double* Hm = G + NT * NP;
        double* Hp = Hm + PC_NZ * NT;
        return pc_predict(F->m, F->d, x, x + NQ, t, h, (int)n, 1, z, Fx, NULL, NP ? G : NULL, Hm, NULL,
                          NP ? Hp : NULL);
    }
#endif
    (void)want_jac;
    return pc_predict(F->m, F->d, x, x + NQ, t, h, (int)n, 0, z, NULL, NULL, NULL, NULL, NULL, NULL);
}

/* the plant flies [t, t + H] (its own time) from its state or x_corr; the master then stands at t_master */
static int fly(pc_fmu_t* F, const char* function, double t, double H, double t_master) {
    double x[NX], x0[NX], h;
    long n;
    int want_jac = PC_STEP_JACOBIAN && F->c.jreq > 0.5;
    if (start_state(F, function, x) != PC_FMU_OK) return PC_FMU_ERROR;
    memcpy(x0, x, sizeof x);
    n = internal_steps(H, &h);
    push_settings(F);
    if (advance(F, x, t, h, n, want_jac)) {
        F->c.mode = PC_MODE_ERROR;
        return pc_fmu_fail(F, function, "the step from t = %.17g s failed: %s", t, pc_error_message(F->d));
    }
    sensed_means(x0, x, t, t + H, F->c.sens);
    F->c.sensed = 1;
    memcpy(F->c.x, x, sizeof x);
    if (want_jac) memcpy(F->c.jac, F->scratch, sizeof F->c.jac);
    else memset(F->c.jac, 0, sizeof F->c.jac);
    F->c.jac_valid = want_jac;
    F->c.time = t + H;
    F->c.last_ok_time = t_master;
    F->out_valid = 0;
    return PC_FMU_OK;
}

int pc_fmu_do_step(pc_fmu_t* F, const char* function, double t, double H) {
    if (check_step(F, function, t, H) != PC_FMU_OK) return PC_FMU_ERROR;
    return fly(F, function, t + PC_LEAD, H, t + H);
}

/* ------------------------------------------------------------------------------------ FMU state */
/* The index of the first of v[0..n) that is not finite (or beyond PC_MAX_ABS); -1 when all are. */
static int first_not_finite(const double* v, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!(fabs(v[i]) <= PC_MAX_ABS)) return i;
    return -1;
}

/* A state's times and flags: finite times, a known mode, a jacobian_valid of 0 or 1. */
static int check_state_flags(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    if (!(fabs(s->time) < PC_MAX_ABS) || !(fabs(s->last_ok_time) < PC_MAX_ABS))
        return pc_fmu_fail(F, function, "the state's time %.17g is not finite", s->time);
    if (s->mode < PC_MODE_INSTANTIATED || s->mode > PC_MODE_ERROR || (s->jac_valid != 0 && s->jac_valid != 1) ||
        (s->sensed != 0 && s->sensed != 1))
        return pc_fmu_fail(F, function, "not a state of this FMU (mode %d)", s->mode);
    return PC_FMU_OK;
}

/* A state's x: finite entries and a unit attitude quaternion. */
static int check_state_x(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    double nq = quat_norm(s->x);
    int i = first_not_finite(s->x, NX);
    if (i >= 0)
        return pc_fmu_fail(F, function, "the state's %s = %.17g: expected a finite number", vr_name(PC_VR_X + i), s->x[i]);
    if (!(fabs(nq - 1.0) <= PC_QUAT_TOL))
        return pc_fmu_fail(F, function, "the state's attitude quaternion q[4..7] has norm %.17g: expected 1 within %g", nq,
                           PC_QUAT_TOL);
    return PC_FMU_OK;
}

/* A state's parameters: finite and at least their bounds. */
static int check_state_p_bounds(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    int i;
    for (i = 0; i < NP; i++)
        if (!(s->p[i] >= PC_P_MIN[i]) || !(fabs(s->p[i]) <= PC_MAX_ABS))
            return pc_fmu_fail(F, function, "the state's %s = %.17g: expected a finite number of at least %.17g",
                               vr_name(PC_VR_P + i), s->p[i], PC_P_MIN[i]);
    return PC_FMU_OK;
}

/* A state's inputs, correction, reset and Jacobian request, Jacobian outputs and sampled sensors: all finite. */
static int check_state_inputs(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    int i = first_not_finite(s->u, PC_NU);
    if (i >= 0)
        return pc_fmu_fail(F, function, "the state's %s = %.17g: expected a finite number", vr_name(PC_VR_U + i), s->u[i]);
    i = first_not_finite(s->xc, NX);
    if (i >= 0)
        return pc_fmu_fail(F, function, "the state's %s = %.17g: expected a finite number", vr_name(PC_VR_XC + i), s->xc[i]);
    if (!(fabs(s->reset) <= PC_MAX_ABS) || !(fabs(s->jreq) <= PC_MAX_ABS))
        return pc_fmu_fail(F, function, "the state's reset or jacobian_request is not finite");
    if (first_not_finite(s->jac, NJAC) >= 0) return pc_fmu_fail(F, function, "the state's Jacobian outputs are not finite");
    if (first_not_finite(s->sens, 6) >= 0) return pc_fmu_fail(F, function, "the state's sampled sensors are not finite");
    return PC_FMU_OK;
}

/* A state's parameters as the core sees them: tried, then the current ones put back (they stay until the
 * state is applied). */
static int check_state_core_params(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    if (NP && pc_set_params(F->m, F->d, s->p)) {
        int code = pc_fmu_fail(F, function, "the state's parameters are refused: %s", pc_error_message(F->d));
        pc_set_params(F->m, F->d, F->c.p);
        return code;
    }
    if (NP) pc_set_params(F->m, F->d, F->c.p); /* the current ones stay until the state is applied */
    return PC_FMU_OK;
}

/* Every reason a saved or deserialised state cannot be this FMU's: non-finite entries, a quaternion
 * that is not unit, parameters below their bounds or refused by the core, an unknown mode. */
static int check_state(pc_fmu_t* F, const char* function, const pc_fmu_state_t* s) {
    if (check_state_flags(F, function, s) != PC_FMU_OK || check_state_x(F, function, s) != PC_FMU_OK ||
        check_state_p_bounds(F, function, s) != PC_FMU_OK || check_state_inputs(F, function, s) != PC_FMU_OK)
        return PC_FMU_ERROR;
    return check_state_core_params(F, function, s);
}

int pc_fmu_get_state(pc_fmu_t* F, const char* function, void** state) {
    if (!*state) *state = malloc(sizeof(pc_fmu_state_t));
    if (!*state) return pc_fmu_fail(F, function, "out of memory");
    memcpy(*state, &F->c, sizeof(pc_fmu_state_t));
    return PC_FMU_OK;
}

int pc_fmu_set_state(pc_fmu_t* F, const char* function, const void* state) {
    const pc_fmu_state_t* s = (const pc_fmu_state_t*)state;
    if (!s) return pc_fmu_fail(F, function, "null state");
    if (check_state(F, function, s) != PC_FMU_OK) return PC_FMU_ERROR;
    memcpy(&F->c, s, sizeof(pc_fmu_state_t));
    F->out_valid = 0;
    return PC_FMU_OK;
}

void pc_fmu_free_state(void** state) {
    if (state && *state) { free(*state); *state = NULL; }
}

size_t pc_fmu_serialized_size(void) { return PC_HEADER_SIZE + sizeof(pc_fmu_state_t); }

int pc_fmu_serialize(pc_fmu_t* F, const char* function, const void* state, char* bytes, size_t size) {
    uint32_t header[4] = {PC_STATE_MAGIC, PC_STATE_VERSION, (uint32_t)sizeof(pc_fmu_state_t), 0};
    if (!state) return pc_fmu_fail(F, function, "null state");
    header[3] = guid_hash();
    if (size < pc_fmu_serialized_size()) return pc_fmu_fail(F, function, "buffer too small");
    memcpy(bytes, header, PC_HEADER_SIZE);
    memcpy(bytes + PC_HEADER_SIZE, state, sizeof(pc_fmu_state_t));
    return PC_FMU_OK;
}

int pc_fmu_deserialize(pc_fmu_t* F, const char* function, const char* bytes, size_t size, void** state) {
    uint32_t header[4];
    pc_fmu_state_t* s;
    if (size != pc_fmu_serialized_size()) return pc_fmu_fail(F, function, "wrong size %lu", (unsigned long)size);
    memcpy(header, bytes, PC_HEADER_SIZE);
    if (header[0] != PC_STATE_MAGIC || header[1] != PC_STATE_VERSION || header[2] != sizeof(pc_fmu_state_t) ||
        header[3] != guid_hash())
        return pc_fmu_fail(F, function, "not a state of this FMU");
    s = (pc_fmu_state_t*)malloc(sizeof(pc_fmu_state_t));
    if (!s) return pc_fmu_fail(F, function, "out of memory");
    memcpy(s, bytes + PC_HEADER_SIZE, sizeof(pc_fmu_state_t));
    if (check_state(F, function, s) != PC_FMU_OK) {
        free(s);
        return PC_FMU_ERROR;
    }
    pc_fmu_free_state(state);
    *state = s;
    return PC_FMU_OK;
}
