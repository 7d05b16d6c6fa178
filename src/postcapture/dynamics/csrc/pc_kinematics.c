/*
 * postcapture plant core: kinematics and the recorded outputs. Owns the joint placements of a
 * configuration (in the parent, and in the world frame N), the centre of mass, the panels' output
 * frames (tip deflection in the root frame, torsion) and their Jacobians, the accelerometer and arm
 * measurement z, and everything a truth run records at a sample (accelerations, panel outputs,
 * momenta, energies, z).
 */
#include "pc_internal.h"

/* placements of every joint in its parent at q (and cos/sin of the revolute angles) */
void pc_kinematics(const pc_model_t* m, pc_data_t* d, const double* q) {
    int i;
    for (i = 0; i < m->nj; i++) {
        const pc_joint_t* J = &m->joints[i];
        double* R = d->Rl + 9 * i;
        double* p = d->pl + 3 * i;
        double Rq[9], t[3];
        if (J->kind < 0) {
            quat_to_matrix(q + J->iq + 3, Rq);
            mm3(J->R, Rq, R);
            mv3(J->R, q + J->iq, t);
            p[0] = J->p[0] + t[0]; p[1] = J->p[1] + t[1]; p[2] = J->p[2] + t[2];
        } else {
            axis_rotation(J->kind, q[J->iq], Rq);
            d->csl[2 * i] = Rq[4 * ((J->kind + 1) % 3)];
            d->csl[2 * i + 1] = Rq[3 * ((J->kind + 2) % 3) + (J->kind + 1) % 3];
            if (J->axis_only) memcpy(R, Rq, sizeof Rq);
            else mm3(J->R, Rq, R);
            p[0] = J->p[0]; p[1] = J->p[1]; p[2] = J->p[2];
        }
    }
}

/* world placements from the parent placements of pc_kinematics */
void pc_world_placements(const pc_model_t* m, pc_data_t* d) {
    int i;
    for (i = 0; i < m->nj; i++) {
        int par = m->joints[i].parent;
        double* Ro = d->Ro + 9 * i;
        double* po = d->po + 3 * i;
        if (par < 0) {
            memcpy(Ro, d->Rl + 9 * i, 9 * sizeof(double));
            memcpy(po, d->pl + 3 * i, 3 * sizeof(double));
        } else {
            double t[3];
            mm3(d->Ro + 9 * par, d->Rl + 9 * i, Ro);
            mv3(d->Ro + 9 * par, d->pl + 3 * i, t);
            po[0] = d->po[3 * par] + t[0]; po[1] = d->po[3 * par + 1] + t[1]; po[2] = d->po[3 * par + 2] + t[2];
        }
    }
}

/* mass and first moment about N's origin of the whole tree (world placements of q computed) */
static double first_moment(const pc_model_t* m, const pc_data_t* d, double* mc) {
    double mass = 0.0;
    int i, k;
    mc[0] = mc[1] = mc[2] = 0.0;
    for (i = 0; i < m->nj; i++) {
        const double* pi = d->pi + 10 * i;
        double c[3];
        mv3(d->Ro + 9 * i, pi + 1, c);
        mass += pi[0];
        for (k = 0; k < 3; k++) mc[k] += c[k] + pi[0] * d->po[3 * i + k];
    }
    return mass;
}

int pc_center_of_mass(const pc_model_t* m, pc_data_t* d, const double* q, double* com) {
    double mass;
    int k;
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    mass = first_moment(m, d, com);
    if (!(mass > 0.0)) {
        pc_set_error(d, "centre of mass: the tree has no mass");
        return PC_ERR_ARG;
    }
    for (k = 0; k < 3; k++) com[k] /= mass;
    return PC_OK;
}

/* z = [accelerometer (3, B components), arm joint accelerations (n_arm; zero when locked)]:
 * a = dv/dt + w x v + dw/dt x r + w x (w x r) with the root's body twist (v, w). */
void pc_measurement(const pc_model_t* m, const double* v, const double* ddq, double* z) {
    double wv[3], dwr[3], wr[3], wwr[3];
    int i;
    if (!m->free_flyer) { /* a chain on a fixed base: no chaser to carry an accelerometer */
        for (i = 0; i < m->nz; i++) z[i] = 0.0;
        return;
    }
    cross3(v + 3, v, wv);
    cross3(ddq + 3, m->r_acc, dwr);
    cross3(v + 3, m->r_acc, wr);
    cross3(v + 3, wr, wwr);
    for (i = 0; i < 3; i++) z[i] = ddq[i] + wv[i] + dwr[i] + wwr[i];
    for (i = 0; i < m->n_arm; i++) z[3 + i] = i < m->n_arm_v ? ddq[m->arm_v[i]] : 0.0;
}

/* World placement of a panel's root frame (its joint may be the universe, -1, for a chain on a fixed base). */
static void root_frame(const pc_data_t* d, const pc_panel_t* P, double* Rr, double* pr) {
    double t3[3];
    int k;
    if (P->root_joint < 0) {
        memcpy(Rr, P->R, 9 * sizeof(double));
        memcpy(pr, P->p, 3 * sizeof(double));
        return;
    }
    mm3(d->Ro + 9 * P->root_joint, P->R, Rr);
    mv3(d->Ro + 9 * P->root_joint, P->p, t3);
    for (k = 0; k < 3; k++) pr[k] = d->po[3 * P->root_joint + k] + t3[k];
}

/* the panel's root frame and its tip point in the world (world placements computed) */
static void panel_frames(const pc_data_t* d, const pc_panel_t* P, double* Rr, double* pr, double* pt) {
    double t3[3];
    int k;
    root_frame(d, P, Rr, pr);
    mv3(d->Ro + 9 * P->tip_joint, P->tip, t3);
    for (k = 0; k < 3; k++) pt[k] = d->po[3 * P->tip_joint + k] + t3[k];
}

static void panel_outputs(const pc_model_t* m, const pc_data_t* d, const double* q, double* out) {
    int i, k, off = m->nq - m->nv;
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        double Rr[9], pr[3], pt[3], dd[3];
        panel_frames(d, P, Rr, pr, pt);
        for (k = 0; k < 3; k++) dd[k] = pt[k] - pr[k];
        mtv3(Rr, dd, out + 4 * i);
        out[4 * i] -= P->length;
        out[4 * i + 3] = P->torsion_v >= 0 ? q[P->torsion_v + off] : 0.0;
    }
}

/* Per panel: the tip deflection in the panel's root frame (3, the undeformed tip at (length, 0, 0)
 * subtracted) and the root torsion angle. */
int pc_panel_outputs(const pc_model_t* m, pc_data_t* d, const double* q, double* out) {
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    panel_outputs(m, d, q, out);
    return PC_OK;
}

/* d(panel outputs)/dq (4 npanels x nv, tangent; the tip in the root frame depends on the panel's own
 * joints only: a revolute joint j on the chain moves the tip by a_j x (p_tip - o_j)). */
int pc_panel_jacobian(const pc_model_t* m, pc_data_t* d, const double* q, double* J) {
    int i, k, nv = m->nv;
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    memset(J, 0, (size_t)4 * m->npanels * nv * sizeof(double));
    for (i = 0; i < m->npanels; i++) {
        const pc_panel_t* P = &m->panels[i];
        double Rr[9], pr[3], pt[3];
        int j = P->tip_joint;
        panel_frames(d, P, Rr, pr, pt);
        while (j >= 0 && j != P->root_joint) {
            const pc_joint_t* Jn = &m->joints[j];
            if (Jn->kind >= 0) {
                double a[3], r[3], c[3], loc[3];
                for (k = 0; k < 3; k++) { a[k] = d->Ro[9 * j + 3 * k + Jn->kind]; r[k] = pt[k] - d->po[3 * j + k]; }
                cross3(a, r, c);
                mtv3(Rr, c, loc);
                for (k = 0; k < 3; k++) J[(size_t)(4 * i + k) * nv + Jn->iv] = loc[k];
            }
            j = Jn->parent;
        }
        if (P->torsion_v >= 0) J[(size_t)(4 * i + 3) * nv + P->torsion_v] = 1.0;
    }
    return PC_OK;
}

/* d R(x, y, z, w) / d(component c), Eigen's formula (R is quadratic in the components) */
static void quat_matrix_partial(const double* a, int c, double* S) {
    double x = a[0], y = a[1], z = a[2], w = a[3];
    const double D[4][9] = {
        {0, 2 * y, 2 * z, 2 * y, -4 * x, -2 * w, 2 * z, 2 * w, -4 * x},
        {-4 * y, 2 * x, 2 * w, 2 * x, 0, 2 * z, -2 * w, 2 * z, -4 * y},
        {-4 * z, -2 * w, 2 * x, 2 * w, -4 * z, 2 * y, 2 * x, 2 * y, 0},
        {0, -2 * z, 2 * y, 2 * z, 0, -2 * x, -2 * y, 2 * x, 0},
    };
    memcpy(S, D[c], 9 * sizeof(double));
}

/* d(panel outputs)/d(root quaternion components x, y, z, w) in the ambient configuration (4 npanels x
 * 4). The tips are relative to the root body, so they move only when the quaternion's norm changes the
 * matrix it is read as (Eigen's formula): tip = A^T R0^T R0 b, with A and b the root frame and the tip
 * in root-body axes; exact at a unit quaternion. */
int pc_panel_quat_jacobian(const pc_model_t* m, pc_data_t* d, const double* q, double* J) {
    double R0[9], dR[4][9];
    int i, c, k, r, l;
    pc_kinematics(m, d, q);
    pc_world_placements(m, d);
    quat_to_matrix(q + 3, R0);
    for (c = 0; c < 4; c++) quat_matrix_partial(q + 3, c, dR[c]);
    memset(J, 0, (size_t)16 * m->npanels * sizeof(double));
    for (i = 0; i < m->npanels; i++) {
        double Rr[9], pr[3], pt[3], dd[3], A[9], b[3];
        panel_frames(d, &m->panels[i], Rr, pr, pt);
        for (k = 0; k < 3; k++) dd[k] = pt[k] - pr[k];
        for (r = 0; r < 3; r++)
            for (k = 0; k < 3; k++) A[3 * r + k] = R0[r] * Rr[k] + R0[3 + r] * Rr[3 + k] + R0[6 + r] * Rr[6 + k];
        mtv3(R0, dd, b);
        for (c = 0; c < 4; c++) {
            double S[9], Sb[3], col[3];
            for (r = 0; r < 3; r++)
                for (k = 0; k < 3; k++) {
                    double s1 = 0.0;
                    for (l = 0; l < 3; l++) s1 += dR[c][3 * l + r] * R0[3 * l + k] + R0[3 * l + r] * dR[c][3 * l + k];
                    S[3 * r + k] = s1;
                }
            mv3(S, b, Sb);
            mtv3(A, Sb, col);
            for (k = 0; k < 3; k++) J[(size_t)(4 * i + k) * 4 + c] = col[k];
        }
    }
    return PC_OK;
}

/* momenta and energies: mech = [centre of mass (3), linear momentum (3), angular momentum about the
 * centre of mass (3), kinetic energy, elastic energy] in N (body twists of the last ABA, world placements) */
static void mechanics(const pc_model_t* m, const pc_data_t* d, const double* q, double* mech) {
    double mc[3], P[3] = {0, 0, 0}, H[3] = {0, 0, 0}, ke = 0.0, cp[3], mass;
    int i, k;
    for (i = 0; i < m->nj; i++) {
        double h[6], hw[6];
        inertia_mul(d->pi + 10 * i, d->vj + 6 * i, h);
        ke += 0.5 * dot6(d->vj + 6 * i, h);
        force_act(d->Ro + 9 * i, d->po + 3 * i, h, hw);
        for (k = 0; k < 3; k++) { P[k] += hw[k]; H[k] += hw[3 + k]; }
    }
    mass = first_moment(m, d, mc);
    for (k = 0; k < 3; k++) mc[k] /= mass;
    cross3(mc, P, cp);
    for (k = 0; k < 3; k++) { mech[k] = mc[k]; mech[3 + k] = P[k]; mech[6 + k] = H[k] - cp[k]; }
    mech[9] = ke;
    mech[10] = pc_elastic_energy(m, d, q);
}

/* Everything recorded at a sample: ddq (nv), the panels' outputs (4 each), and mech (11, see
 * mechanics) followed by the measurement z (nz). */
int pc_sample(const pc_model_t* m, pc_data_t* d, const double* q, const double* v, double t, double* ddq,
              double* panels, double* mech) {
    size_t mark = PC_ARENA_MARK(d);
    double* u = pc_arena_alloc(d, (size_t)m->nu + 1);
    int err;
    if (!u) return PC_ERR_MEMORY;
    pc_inputs_at(m, d, t, 0, u);
    pc_orbit_time(d, t);
    err = pc_accel(m, d, q, v, u, ddq);
    PC_ARENA_RELEASE(d, mark);
    if (err) return err;
    pc_world_placements(m, d); /* pc_accel left the joint placements of q */
    if (mech) {
        mechanics(m, d, q, mech);
        pc_measurement(m, v, ddq, mech + 11);
    }
    if (panels) panel_outputs(m, d, q, panels);
    return PC_OK;
}
