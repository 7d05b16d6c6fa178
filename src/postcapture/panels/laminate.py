"""Classical lamination theory (CLT) for the sandwich solar panels.

A `Laminate` is a stack of `Ply` objects listed from the bottom (``z = -h/2``) to the top
(``z = +h/2``) face, each an `OrthotropicMaterial` rotated by its orientation angle about the panel
normal. The reference surface is the mid-thickness, as for a Nastran PCOMP with its default ``Z0``.
A honeycomb core is one more ply, with a material whose in-plane moduli are negligible and whose
transverse shear moduli ``g13``/``g23`` are the core's ribbon-direction and transverse shear moduli.

The solar cells, as in the reference, are modelled by raising the density of the upper ply: the
laminate keeps their areal mass apart (``cell_mass``), so that the same model can be written either
way to Nastran (per-ply density or non-structural mass, see `postcapture.panels.nastran`).

Axes: 1 along the fibres, 2 across them, 3 along the ply normal (material axes); x, y in the panel
plane with x along the panel length, z along the panel normal (panel frame P). Ply angles are in
degrees, from x towards y.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from postcapture.core.errors import PanelModelError, Problem

__all__ = [
    "OrthotropicMaterial",
    "Ply",
    "Laminate",
]

_MATERIAL_KEYS = ("e1", "e2", "nu12", "g12", "g13", "g23", "rho")
_COUPLING_SUFFIXES = ("16", "26", "36", "45")


def _is_number(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _material_problems(values: Mapping, path: str) -> list[Problem]:
    """Every problem of an orthotropic material given as a mapping of its fields."""
    problems = []
    for key in _MATERIAL_KEYS:
        value = values.get(key)
        if not _is_number(value) or not math.isfinite(value):
            problems.append(Problem(f"{path}.{key}", "a finite number", repr(value)))
        elif key == "rho" and value < 0.0:
            problems.append(Problem(f"{path}.rho", ">= 0 kg/m^3", repr(value)))
        elif key not in ("nu12", "rho") and value <= 0.0:
            problems.append(Problem(f"{path}.{key}", "> 0 Pa (moduli must be positive)", repr(value)))
    e1, e2, nu12 = (values.get(k) for k in ("e1", "e2", "nu12"))
    if all(_is_number(v) and math.isfinite(v) for v in (e1, e2, nu12)) and e1 > 0 and e2 > 0:
        # plane-stress compliance positive definite: 1 - nu12 nu21 > 0, i.e. nu12^2 < e1/e2
        if nu12 * nu12 >= e1 / e2:
            problems.append(Problem(
                f"{path}.nu12",
                f"|nu12| < sqrt(e1/e2) = {math.sqrt(e1 / e2):.6g} (positive-definite orthotropic compliance)",
                repr(nu12)))
    return problems


@dataclass(frozen=True, slots=True)
class OrthotropicMaterial:
    """Orthotropic ply material in its principal axes (plane stress plus transverse shear).

    Parameters
    ----------
    e1, e2 : float
        Young's moduli along and across the fibres (Pa).
    nu12 : float
        Major Poisson's ratio (-); ``nu21 = nu12 e2/e1``.
    g12, g13, g23 : float
        In-plane and transverse shear moduli (Pa).
    rho : float
        Density (kg/m^3).
    name : str, optional
        Label used in files and messages.

    Raises
    ------
    PanelModelError
        If a modulus is not positive, the density negative, a value not finite, or
        ``nu12**2 >= e1/e2`` (the material would not be a positive-definite orthotropic solid).
    """

    e1: float
    e2: float
    nu12: float
    g12: float
    g13: float
    g23: float
    rho: float
    name: str = ""

    def __post_init__(self):
        values = {k: getattr(self, k) for k in _MATERIAL_KEYS}
        problems = _material_problems(values, self.name or "material")
        if problems:
            raise PanelModelError(problems, source=self.name or None)
        for k in _MATERIAL_KEYS:
            object.__setattr__(self, k, float(getattr(self, k)))

    @classmethod
    def isotropic(cls, e: float, nu: float, rho: float, *, name: str = "") -> OrthotropicMaterial:
        """Isotropic material: Young's modulus ``e`` (Pa), Poisson's ratio ``nu`` (-), density (kg/m^3)."""
        g = e / (2.0 * (1.0 + nu))
        return cls(e1=e, e2=e, nu12=nu, g12=g, g13=g, g23=g, rho=rho, name=name)

    @property
    def nu21(self) -> float:
        """Minor Poisson's ratio ``nu12 e2 / e1`` (-)."""
        return self.nu12 * self.e2 / self.e1

    def reduced_stiffness(self) -> np.ndarray:
        """Plane-stress reduced stiffness ``Q`` in material axes, shape (3, 3), order (11, 22, 12) (Pa)."""
        d = 1.0 - self.nu12 * self.nu21
        q11, q22, q12 = self.e1 / d, self.e2 / d, self.nu12 * self.e2 / d
        return np.array([[q11, q12, 0.0], [q12, q22, 0.0], [0.0, 0.0, self.g12]])

    def with_density(self, rho: float) -> OrthotropicMaterial:
        """Return a copy with another density (kg/m^3)."""
        return replace(self, rho=rho)


@dataclass(frozen=True, slots=True)
class Ply:
    """One ply of a laminate.

    Parameters
    ----------
    thickness : float
        Ply thickness (m), > 0.
    angle_deg : float
        Orientation of the material 1-axis from the panel x-axis towards y (deg).
    material : OrthotropicMaterial
        The ply material.

    Raises
    ------
    PanelModelError
        If the thickness is not positive and finite, or the angle not finite.
    """

    thickness: float
    angle_deg: float
    material: OrthotropicMaterial

    def __post_init__(self):
        problems = _ply_problems(self.thickness, self.angle_deg, self.material, "ply")
        if problems:
            raise PanelModelError(problems)
        object.__setattr__(self, "thickness", float(self.thickness))
        object.__setattr__(self, "angle_deg", float(self.angle_deg))

    def transformed_stiffness(self) -> np.ndarray:
        r"""In-plane stiffness ``Qbar`` in panel axes, shape (3, 3), order (xx, yy, xy) (Pa).

        Notes
        -----
        With ``c = cos(theta)``, ``s = sin(theta)`` (the standard CLT transformation, e.g. Jones,
        *Mechanics of Composite Materials*, chapter 2):

        .. math::

            \bar Q_{11} = Q_{11} c^4 + 2 (Q_{12} + 2 Q_{66}) s^2 c^2 + Q_{22} s^4, \quad
            \bar Q_{16} = (Q_{11} - Q_{12} - 2 Q_{66}) s c^3 + (Q_{12} - Q_{22} + 2 Q_{66}) s^3 c, \ldots
        """
        q = self.material.reduced_stiffness()
        q11, q12, q22, q66 = q[0, 0], q[0, 1], q[1, 1], q[2, 2]
        t = math.radians(self.angle_deg)
        c, s = math.cos(t), math.sin(t)
        c2, s2 = c * c, s * s
        qb11 = q11 * c2 * c2 + 2.0 * (q12 + 2.0 * q66) * s2 * c2 + q22 * s2 * s2
        qb22 = q11 * s2 * s2 + 2.0 * (q12 + 2.0 * q66) * s2 * c2 + q22 * c2 * c2
        qb12 = (q11 + q22 - 4.0 * q66) * s2 * c2 + q12 * (s2 * s2 + c2 * c2)
        qb66 = (q11 + q22 - 2.0 * q12 - 2.0 * q66) * s2 * c2 + q66 * (s2 * s2 + c2 * c2)
        qb16 = (q11 - q12 - 2.0 * q66) * s * c2 * c + (q12 - q22 + 2.0 * q66) * s2 * s * c
        qb26 = (q11 - q12 - 2.0 * q66) * s2 * s * c + (q12 - q22 + 2.0 * q66) * s * c2 * c
        return np.array([[qb11, qb12, qb16], [qb12, qb22, qb26], [qb16, qb26, qb66]])

    def transformed_shear_stiffness(self) -> np.ndarray:
        """Transverse shear stiffness in panel axes, shape (2, 2), order (yz, xz) (Pa)."""
        m = self.material
        t = math.radians(self.angle_deg)
        c, s = math.cos(t), math.sin(t)
        c44 = m.g23 * c * c + m.g13 * s * s
        c55 = m.g13 * c * c + m.g23 * s * s
        c45 = (m.g13 - m.g23) * c * s
        return np.array([[c44, c45], [c45, c55]])


def _ply_problems(thickness, angle_deg, material, path: str, *, check_material: bool = True) -> list[Problem]:
    problems = []
    if not _is_number(thickness) or not math.isfinite(thickness) or thickness <= 0.0:
        problems.append(Problem(f"{path}.thickness", "a finite thickness > 0 m", repr(thickness)))
    if not _is_number(angle_deg) or not math.isfinite(angle_deg):
        problems.append(Problem(f"{path}.angle_deg", "a finite angle (deg)", repr(angle_deg)))
    if check_material and not isinstance(material, OrthotropicMaterial):
        problems.append(Problem(f"{path}.material", "an OrthotropicMaterial", type(material).__name__))
    return problems


@dataclass(frozen=True, slots=True)
class Laminate:
    """A ply stack, bottom to top, with the solar cells' areal mass on the top face.

    Parameters
    ----------
    plies : sequence of Ply
        The structural plies from the bottom (``z = -h/2``) to the top face (``z = +h/2``); at least one.
    cell_mass : float, optional
        Areal mass of the solar cells, cover glass, adhesive and harness on the top face (kg/m^2).
        The mass matrices carry it, as the reference does, in the density of the upper ply
        (see `effective_plies`). Default 0.
    name : str, optional
        Label used in files and messages.

    Raises
    ------
    PanelModelError
        If the ply list is empty, an entry is not a `Ply`, or ``cell_mass`` is negative or not finite.
    """

    plies: tuple[Ply, ...]
    cell_mass: float = 0.0
    name: str = field(default="")

    def __post_init__(self):
        plies = tuple(self.plies)
        problems = []
        if not plies:
            problems.append(Problem("plies", "at least one ply", "an empty list"))
        for i, ply in enumerate(plies):
            if not isinstance(ply, Ply):
                problems.append(Problem(f"plies[{i}]", "a Ply", type(ply).__name__))
        cm = self.cell_mass
        if not _is_number(cm) or not math.isfinite(cm) or cm < 0.0:
            problems.append(Problem("cell_mass", "a finite areal mass >= 0 kg/m^2", repr(cm)))
        if problems:
            raise PanelModelError(problems, source=self.name or None)
        object.__setattr__(self, "plies", plies)
        object.__setattr__(self, "cell_mass", float(cm))

    @classmethod
    def from_dict(cls, spec: Mapping, *, source: str | None = None) -> Laminate:
        """Build a laminate from plain data (for example a parsed TOML table), collecting every problem.

        Parameters
        ----------
        spec : mapping
            ``{"name": str, "cell_mass": float, "materials": {name: {e1, e2, nu12, g12, g13, g23, rho}},
            "plies": [{"thickness": float, "angle_deg": float, "material": name}, ...]}`` in SI units,
            plies from the bottom to the top face. ``name`` and ``cell_mass`` are optional.
        source : str, optional
            File or name quoted in the error message.

        Returns
        -------
        Laminate

        Raises
        ------
        PanelModelError
            With every problem found (unknown keys, missing or non-positive values, unknown material
            names, zero-thickness plies, ...), not only the first one.
        """
        problems: list[Problem] = []
        unknown = set(spec) - {"name", "cell_mass", "materials", "plies"}
        problems += [Problem(k, "one of name, cell_mass, materials, plies", "an unknown key")
                     for k in sorted(unknown)]
        materials: dict[str, OrthotropicMaterial] = {}
        for mname, mspec in dict(spec.get("materials", {})).items():
            path = f"materials.{mname}"
            extra = set(mspec) - set(_MATERIAL_KEYS)
            for k in sorted(extra):
                if k.endswith(_COUPLING_SUFFIXES):  # e.g. g16, e26, c45: an anisotropic coupling term
                    problems.append(Problem(f"{path}.{k}", "an orthotropic material (no coupling terms)",
                                            "a coupling modulus"))
                else:
                    problems.append(Problem(f"{path}.{k}", f"one of {', '.join(_MATERIAL_KEYS)}",
                                            "an unknown key"))
            mp = _material_problems(mspec, path)
            problems += mp
            if not mp and not extra:
                materials[mname] = OrthotropicMaterial(**{k: mspec[k] for k in _MATERIAL_KEYS}, name=mname)
        plies = []
        pspecs = spec.get("plies", [])
        if not pspecs:
            problems.append(Problem("plies", "at least one ply", "none"))
        for i, pspec in enumerate(pspecs):
            path = f"plies[{i}]"
            mname = pspec.get("material")
            if mname not in dict(spec.get("materials", {})):
                problems.append(Problem(f"{path}.material", "the name of a material in 'materials'",
                                        repr(mname)))
            pp = _ply_problems(pspec.get("thickness"), pspec.get("angle_deg", 0.0), None, path,
                               check_material=False)
            problems += pp
            if not pp and mname in materials:
                plies.append(Ply(pspec["thickness"], pspec.get("angle_deg", 0.0), materials[mname]))
        cell_mass = spec.get("cell_mass", 0.0)
        if not _is_number(cell_mass) or not math.isfinite(cell_mass) or cell_mass < 0.0:
            problems.append(Problem("cell_mass", "a finite areal mass >= 0 kg/m^2", repr(cell_mass)))
        if problems:
            raise PanelModelError(problems, source=source or spec.get("name"))
        return cls(tuple(plies), cell_mass=cell_mass, name=str(spec.get("name", "")))

    @property
    def thickness(self) -> float:
        """Total thickness ``h`` (m)."""
        return float(sum(p.thickness for p in self.plies))

    @property
    def interfaces(self) -> np.ndarray:
        """Ply interface coordinates from ``-h/2`` to ``+h/2``, shape (n_plies + 1,) (m)."""
        z = np.concatenate([[0.0], np.cumsum([p.thickness for p in self.plies])])
        return z - 0.5 * z[-1]

    def effective_plies(self) -> tuple[Ply, ...]:
        """Return the plies with the cell mass smeared into the density of the top ply (as the reference)."""
        if self.cell_mass == 0.0:
            return self.plies
        top = self.plies[-1]
        rho = top.material.rho + self.cell_mass / top.thickness
        return self.plies[:-1] + (replace(top, material=top.material.with_density(rho)),)

    @property
    def areal_mass(self) -> float:
        """Mass per unit area including the cells (kg/m^2)."""
        return float(sum(p.thickness * p.material.rho for p in self.plies)) + self.cell_mass

    def mass_moments(self) -> tuple[float, float, float]:
        """Mass integrals ``(int rho dz, int rho z dz, int rho z^2 dz)``, the cells in the top ply.

        Returns
        -------
        tuple of float
            (kg/m^2, kg/m, kg) per unit area.
        """
        z = self.interfaces
        rho = np.array([p.material.rho for p in self.effective_plies()])
        return (float(np.sum(rho * np.diff(z))), float(np.sum(rho * np.diff(z**2)) / 2.0),
                float(np.sum(rho * np.diff(z**3)) / 3.0))

    def abd(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Membrane, coupling and bending stiffness matrices of classical lamination theory.

        Returns
        -------
        A : ndarray, shape (3, 3)
            ``sum Qbar_k (z_k - z_{k-1})`` (N/m).
        B : ndarray, shape (3, 3)
            ``sum Qbar_k (z_k^2 - z_{k-1}^2) / 2`` (N).
        D : ndarray, shape (3, 3)
            ``sum Qbar_k (z_k^3 - z_{k-1}^3) / 3`` (N m).

        Notes
        -----
        Order (xx, yy, xy) with engineering shear strain, so that
        ``[N; M] = [[A, B], [B, D]] [eps0; kappa]``.
        """
        z = self.interfaces
        a = np.zeros((3, 3))
        b = np.zeros((3, 3))
        d = np.zeros((3, 3))
        for k, ply in enumerate(self.plies):
            q = ply.transformed_stiffness()
            a += q * (z[k + 1] - z[k])
            b += q * (z[k + 1] ** 2 - z[k] ** 2) / 2.0
            d += q * (z[k + 1] ** 3 - z[k] ** 3) / 3.0
        return a, b, d

    def abd_matrix(self) -> np.ndarray:
        """Return the 6 x 6 matrix ``[[A, B], [B, D]]`` (N/m, N, N m blocks)."""
        a, b, d = self.abd()
        return np.block([[a, b], [b, d]])

    def transverse_shear(self) -> np.ndarray:
        """Uncorrected transverse shear stiffness ``sum C_k t_k``, shape (2, 2), order (yz, xz) (N/m).

        Notes
        -----
        For a sandwich the core carries nearly all of it; a FE code applies its own correction
        (pyfe3d: Rohwer's equilibrium approach; Nastran: from the PCOMP plies).
        """
        return sum(p.transformed_shear_stiffness() * p.thickness for p in self.plies)

    def is_symmetric(self, *, rtol: float = 1e-12) -> bool:
        """Tell whether the stiffness is mid-plane symmetric (``B`` vanishes to ``rtol`` of ``A h``)."""
        a, b, _ = self.abd()
        return bool(np.max(np.abs(b)) <= rtol * np.max(np.abs(a)) * self.thickness)
