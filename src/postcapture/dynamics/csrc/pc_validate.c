/*
 * postcapture plant core: pc_validate, the model's one check at the boundary (as MuJoCo's
 * mj_validateReferences). Owns every rule the recursions rely on: each index within its range, the
 * joints numbered depth first with their coordinates in order, finite numbers, orthonormal rotations,
 * sorted tables. A model that passes may be used without further checks; one that fails is refused by
 * pc_model_create with the first problem found, naming the entry.
 */
#include "pc_internal.h"

#define bad pc_model_error

static int finite_all(const double* x, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!(fabs(x[i]) < INFINITY)) return 0;
    return 1;
}

static int orthonormal(const double* R) {
    int i, j, k;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            double s = 0.0;
            for (k = 0; k < 3; k++) s += R[3 * k + i] * R[3 * k + j];
            if (fabs(s - (i == j)) > 1e-9) return 0;
        }
    return 1;
}

static int check_joint(const pc_model_t* m, int i, int iq, int iv, char* err, size_t n) {
    const pc_joint_t* J = &m->joints[i];
    if (J->parent < -1 || J->parent >= i)
        return bad(err, n, "joint %d: parent %d, expected -1 to %d (parents come first)", i, J->parent, i - 1);
    if (J->kind < -1 || J->kind > 2) return bad(err, n, "joint %d: kind %d, expected -1 (free flyer) or 0, 1, 2", i, J->kind);
    if (J->kind == -1 && (i != 0 || J->parent != -1 || !m->free_flyer))
        return bad(err, n, "joint %d: a free flyer is only allowed as the root of a free-flyer model", i);
    if (i == 0 && m->free_flyer && J->kind != -1) return bad(err, n, "joint 0: the model is flagged free flyer, found kind %d", J->kind);
    if (J->iq != iq || J->iv != iv)
        return bad(err, n, "joint %d: coordinates (iq %d, iv %d), expected (%d, %d) in joint order", i, J->iq, J->iv, iq, iv);
    if (!finite_all(J->R, 9) || !finite_all(J->p, 3) || !finite_all(J->pi, 10))
        return bad(err, n, "joint %d: placement or inertia not finite", i);
    if (!orthonormal(J->R)) return bad(err, n, "joint %d: placement rotation not orthonormal", i);
    return PC_OK;
}

/* Joints: ranges, coordinates in order, and the depth-first numbering the derivatives rely on. */
static int check_joints(const pc_model_t* m, char* err, size_t n) {
    int i, iq = 0, iv = 0, err_code;
    for (i = 0; i < m->nj; i++) {
        if ((err_code = check_joint(m, i, iq, iv, err, n))) return err_code;
        iq += m->joints[i].kind < 0 ? 7 : 1;
        iv += m->joints[i].kind < 0 ? 6 : 1;
    }
    if (iq != m->nq || iv != m->nv) return bad(err, n, "joints: %d configuration and %d velocity coordinates, header says %d and %d", iq, iv, m->nq, m->nv);
    for (i = 1; i < m->nj; i++) {
        /* depth first: a joint's parent is the previous joint or one of its ancestors */
        int a = i - 1, p = m->joints[i].parent;
        while (a >= 0 && a != p) a = m->joints[a].parent;
        if (a != p) return bad(err, n, "joint %d: not numbered depth first (parent %d)", i, p);
    }
    return PC_OK;
}

/* A velocity index of an elastic coordinate: [n_root_v, nv). */
static int elastic(const pc_model_t* m, int v) { return v >= m->n_root_v && v < m->nv; }

static int check_springs(const pc_model_t* m, char* err, size_t n) {
    int i;
    for (i = 0; i < m->ns; i++) {
        const pc_spring_t* S = &m->springs[i];
        if (!elastic(m, S->v[0])) return bad(err, n, "spring %d: velocity index %d, expected %d to %d", i, S->v[0], m->n_root_v, m->nv - 1);
        if (S->v[1] != -1 && (!elastic(m, S->v[1]) || S->v[1] == S->v[0]))
            return bad(err, n, "spring %d: second velocity index %d, expected -1 or another of %d to %d", i, S->v[1], m->n_root_v, m->nv - 1);
        if (S->pk < -1 || S->pk >= m->np || S->pd < -1 || S->pd >= m->np)
            return bad(err, n, "spring %d: parameter indices (%d, %d), expected -1 to %d", i, S->pk, S->pd, m->np - 1);
        if (!finite_all(S->a, 2) || !(S->k0 >= 0.0 && S->k0 < INFINITY) || !(S->d0 >= 0.0 && S->d0 < INFINITY) ||
            !(fabs(S->rest) < INFINITY))
            return bad(err, n, "spring %d: coefficients, stiffness, damping or rest not finite (or negative)", i);
    }
    return PC_OK;
}

static int check_profile(const pc_model_t* m, int i, char* err, size_t n) {
    const pc_profile_t* P = &m->prof[i];
    int k;
    if (P->kind < PC_PROFILE_STEP || P->kind > PC_PROFILE_TABLE) return bad(err, n, "profile %d: kind %d, expected 0 to 3", i, P->kind);
    if (P->channel < 0 || P->channel >= m->nu) return bad(err, n, "profile %d: channel %d, expected 0 to %d", i, P->channel, m->nu - 1);
    if (!(fabs(P->start) < INFINITY) || P->stop != P->stop || !finite_all(&P->a, 7))
        return bad(err, n, "profile %d: numbers not finite", i);
    if (P->kind != PC_PROFILE_TABLE) return PC_OK;
    if (P->n_table < 2 || P->table < 0 || P->table > m->ntable - P->n_table)
        return bad(err, n, "profile %d: table [%d, +%d) outside the %d table entries", i, P->table, P->n_table, m->ntable);
    for (k = P->table + 1; k < P->table + P->n_table; k++)
        if (!(m->table_t[k] > m->table_t[k - 1])) return bad(err, n, "profile %d: table times not increasing", i);
    return PC_OK;
}

static int check_inputs(const pc_model_t* m, char* err, size_t n) {
    int i, e;
    for (i = 0; i < m->nu; i++)
        if (m->u_to_v[i] < -1 || m->u_to_v[i] >= m->nv) return bad(err, n, "input %d: velocity index %d, expected -1 to %d", i, m->u_to_v[i], m->nv - 1);
    if (m->custom_b && !finite_all(m->B, m->nv * m->nu)) return bad(err, n, "input matrix: not finite");
    if (!finite_all(m->table_t, m->ntable) || !finite_all(m->table_v, m->ntable)) return bad(err, n, "tables: not finite");
    for (i = 0; i < m->nprof; i++)
        if ((e = check_profile(m, i, err, n))) return e;
    return PC_OK;
}

static int check_outputs(const pc_model_t* m, char* err, size_t n) {
    int i;
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        if (P->root_joint < -1 || P->root_joint >= m->nj || P->tip_joint < 0 || P->tip_joint >= m->nj)
            return bad(err, n, "panel %d: joints (%d, %d), expected -1 to %d and 0 to %d", i, P->root_joint, P->tip_joint, m->nj - 1, m->nj - 1);
        if (P->torsion_v != -1 && !elastic(m, P->torsion_v))
            return bad(err, n, "panel %d: torsion index %d, expected -1 or %d to %d", i, P->torsion_v, m->n_root_v, m->nv - 1);
        if (!finite_all(P->R, 9) || !finite_all(P->p, 3) || !finite_all(P->tip, 3) || !(fabs(P->length) < INFINITY))
            return bad(err, n, "panel %d: frames not finite", i);
    }
    if (m->n_arm_v > m->n_arm) return bad(err, n, "arm: %d joint indices for %d joints", m->n_arm_v, m->n_arm);
    for (i = 0; i < m->n_arm_v; i++)
        if (!elastic(m, m->arm_v[i])) return bad(err, n, "arm joint %d: velocity index %d, expected %d to %d", i, m->arm_v[i], m->n_root_v, m->nv - 1);
    if (!finite_all(m->r_acc, 3)) return bad(err, n, "accelerometer position: not finite");
    return PC_OK;
}

static int check_parameters(const pc_model_t* m, char* err, size_t n) {
    if (m->target_joint < -1 || m->target_joint >= m->nj)
        return bad(err, n, "target joint %d, expected -1 to %d", m->target_joint, m->nj - 1);
    if (m->target_joint >= 0 && m->np < 10)
        return bad(err, n, "target joint given with %d parameters, expected at least its ten inertial ones", m->np);
    if (!finite_all(m->t_L, 100) || !finite_all(m->t_base, 10) || !finite_all(m->p0, m->np))
        return bad(err, n, "target map or nominal parameters not finite");
    return pc_params_problem(m, m->p0, err, n) ? PC_ERR_MODEL : PC_OK;
}

int pc_validate(const pc_model_t* m, char* err, size_t err_size) {
    int e;
    if (m->free_flyer && m->nq != m->nv + 1) return bad(err, err_size, "free flyer: nq %d, expected nv + 1 = %d", m->nq, m->nv + 1);
    if (!m->free_flyer && m->nq != m->nv) return bad(err, err_size, "fixed base: nq %d, expected nv = %d", m->nq, m->nv);
    if ((e = check_joints(m, err, err_size)) || (e = check_springs(m, err, err_size)) ||
        (e = check_inputs(m, err, err_size)) || (e = check_outputs(m, err, err_size)) ||
        (e = check_parameters(m, err, err_size)))
        return e;
    return PC_OK;
}
