"""The CasADi functions an exported FMU calls, and their C code.

Functions (all dense, double precision; ``q (nq), v (nv), u (n_u), p (n_p)``):

==============  ===================================================  ======================================
name            inputs                                               outputs
==============  ===================================================  ======================================
``pc_ddq``      q, v, u, p                                           ddq (nv)
``pc_ddq_jac``  q, v, u, p                                           ddq (nv), J (nv x (n_e + nv + n_m))
``pc_ddq_jvp``  q, v, u, p, dq, dv, du, dp                           d ddq (nv) (forward directional)
``pc_integ``    q, xi                                                q (+) xi (nq)
``pc_dint``     q, xi                                                J0, Jr (6x6 each, free-flyer block)
``pc_out``      q, v, ddq                                            xdot (nx, ambient), y (n_y)
``pc_out_jvp``  q, v, ddq, dq, dv, dddq                              d xdot, d y
``pc_meas``     q, v, ddq                                            z (n_z), dz/dv, dz/dddq (n_z x nv)
==============  ===================================================  ======================================

``J`` holds ``d ddq / d e`` (the elastic angles ``e = q[7:]``; ``ddq`` does not depend on the free
flyer's configuration without gravity), ``d ddq / d v`` and, with a target, ``d ddq / d m``.
``J0`` and ``Jr`` are Pinocchio's ``dIntegrate`` (with respect to ``q`` and to ``xi``) on the free-flyer
block, obtained as ``L(q1)^+ d(q1)/d(.)`` with the ambient derivative of :func:`integrate_free_flyer`.

The large Jacobian goes to its own C file so the two files compile in parallel.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from postcapture.fmi._extras import import_casadi
from postcapture.fmi.symbolic.liegroup import integrate_free_flyer, tangent_basis, tangent_projector
from postcapture.fmi.symbolic.plant import SymbolicPlant

__all__ = ["GeneratedCode", "build_functions", "generate_c"]

_CODEGEN_OPTIONS = {"with_export": False, "verbose": False, "with_header": False, "casadi_int": "int"}


@dataclass
class GeneratedCode:
    """C files generated for a plant and the facts the FMU runtime needs."""

    files: list[Path]
    functions: dict[str, int] = field(default_factory=dict)  # name -> CasADi instruction count
    n_jac_cols: int = 0
    n_y: int = 0
    n_z: int = 0


def build_functions(plant: SymbolicPlant) -> dict:
    """The CasADi functions of the table in the module docstring, by name."""
    ca = import_casadi()
    q, v, u, p = plant.symbols()
    nv = plant.nv
    ddq = plant.acceleration(q, v, u, p)
    funcs = {"pc_ddq": ca.Function("pc_ddq", [q, v, u, p], [ddq])}
    cols = []
    if plant.n_e:
        cols.append(q[plant.n_root_q :])
    cols.append(v)
    if plant.has_target:
        cols.append(p[0])
    wrt = ca.vertcat(*cols)
    J = ca.densify(ca.jacobian(ddq, wrt))
    funcs["pc_ddq_jac"] = ca.Function("pc_ddq_jac", [q, v, u, p], [ddq, J])
    dq, dv, du, dp = (ca.SX.sym(n, s.shape[0]) for n, s in (("dq", q), ("dv", v), ("du", u), ("dp", p)))
    jvp = ca.jtimes(ddq, ca.vertcat(q, v, u, p), ca.vertcat(dq, dv, du, dp))
    funcs["pc_ddq_jvp"] = ca.Function("pc_ddq_jvp", [q, v, u, p, dq, dv, du, dp], [ca.densify(jvp)])
    xi = ca.SX.sym("xi", nv)
    funcs["pc_integ"] = ca.Function("pc_integ", [q, xi], [plant.integrate(q, xi)])
    if plant.free_flyer:
        q0, x6 = ca.SX.sym("q0", 7), ca.SX.sym("xi6", 6)
        q1 = integrate_free_flyer(q0, x6)
        P1 = tangent_projector(q1)
        Jr = P1 @ ca.jacobian(q1, x6)
        J0 = P1 @ ca.jacobian(q1, q0) @ tangent_basis(q0)
        funcs["pc_dint"] = ca.Function("pc_dint", [q0, x6], [ca.densify(J0), ca.densify(Jr)])
    a = ca.SX.sym("a", nv)
    xdot = plant.state_derivative(q, v, a)
    y = plant.outputs(q, v, a)
    funcs["pc_out"] = ca.Function("pc_out", [q, v, a], [ca.densify(xdot), ca.densify(y)])
    da = ca.SX.sym("da", nv)
    seeds = ca.vertcat(dq, dv, da)
    outs = ca.vertcat(xdot, y)
    d_all = ca.jtimes(outs, ca.vertcat(q, v, a), seeds)
    funcs["pc_out_jvp"] = ca.Function(
        "pc_out_jvp", [q, v, a, dq, dv, da], [ca.densify(d_all[: plant.nx]), ca.densify(d_all[plant.nx :])]
    )
    z = plant.measurement(q, v, a)
    funcs["pc_meas"] = ca.Function(
        "pc_meas", [q, v, a], [z, ca.densify(ca.jacobian(z, v)), ca.densify(ca.jacobian(z, a))]
    )
    return funcs


def generate_c(plant: SymbolicPlant, directory: Path) -> GeneratedCode:
    """Write ``pc_model.c`` and ``pc_model_jac.c`` into ``directory``.

    Returns
    -------
    GeneratedCode
    """
    ca = import_casadi()
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    funcs = build_functions(plant)
    files = []
    for fname, names in (
        ("pc_model", [n for n in funcs if n != "pc_ddq_jac"]),
        ("pc_model_jac", ["pc_ddq_jac"]),
    ):
        gen = ca.CodeGenerator(f"{fname}.c", dict(_CODEGEN_OPTIONS))
        for n in names:
            gen.add(funcs[n])
        text = gen.dump()
        path = directory / f"{fname}.c"
        path.write_text(text)
        files.append(path)
    n_cols = funcs["pc_ddq_jac"].size2_out(1)
    return GeneratedCode(
        files=files,
        functions={n: int(f.n_instructions()) for n, f in funcs.items()},
        n_jac_cols=int(n_cols),
        n_y=int(funcs["pc_out"].size1_out(1)),
        n_z=int(funcs["pc_meas"].size1_out(0)),
    )
