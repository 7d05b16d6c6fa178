"""Closed-form cases for the panel tests: a uniform strip and the Euler-Bernoulli cantilever."""

import numpy as np

from postcapture.panels import Laminate, OrthotropicMaterial, PanelGeometry, Ply

BETA_L = np.array([1.8751040687119611, 4.6940911329741745, 7.8547574382376126])  # cos(b) cosh(b) = -1


class Strip:
    """A thin aluminium-like strip: L = 1 m, b = 0.1 m, h = 0.5 mm, one isotropic layer."""

    length, width, thickness = 1.0, 0.1, 0.5e-3
    e, rho = 70e9, 2700.0

    def __init__(self, nu=0.0):
        self.nu = nu
        self.geometry = PanelGeometry(self.length, self.width, name="strip")
        material = OrthotropicMaterial.isotropic(self.e, nu, self.rho)
        self.laminate = Laminate((Ply(self.thickness, 0.0, material),))
        self.ei = self.e * self.width * self.thickness**3 / 12.0  # narrow beam (free anticlastic)
        self.mass_per_length = self.rho * self.width * self.thickness

    def euler_bernoulli_hz(self, mode=1, ei=None):
        """f_n = (beta_n L)^2 / (2 pi) sqrt(EI / (m L^4))."""
        ei = self.ei if ei is None else ei
        return BETA_L[mode - 1] ** 2 / (2 * np.pi) * np.sqrt(ei / (self.mass_per_length * self.length**4))


def beam_frequency(geometry, laminate, mode=1):
    """Euler-Bernoulli cantilever frequency of the laminate's equivalent beam (Hz)."""
    from postcapture.panels import equivalent_beam

    beam = equivalent_beam(laminate, geometry.width)
    ratio = beam.bending_stiffness / (beam.mass_per_length * geometry.length**4)
    return BETA_L[mode - 1] ** 2 / (2 * np.pi) * np.sqrt(ratio)


def euler_bernoulli_shape(x, length, mode=1):
    """Closed-form clamped-free mode shape and slope, normalised to a unit tip deflection."""
    b = BETA_L[mode - 1] / length
    bl = BETA_L[mode - 1]
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    phi = np.cosh(b * x) - np.cos(b * x) - sigma * (np.sinh(b * x) - np.sin(b * x))
    dphi = b * (np.sinh(b * x) + np.sin(b * x) - sigma * (np.cosh(b * x) - np.cos(b * x)))
    tip = np.cosh(bl) - np.cos(bl) - sigma * (np.sinh(bl) - np.sin(bl))
    return phi / tip, dphi / tip


def write_modes_op2(path, node_ids, shapes, frequencies_hz, *, eigenvectors=True):
    """Write an OP2 with pyNastran's own writer from known modes (LAMA + OUGV1 eigenvectors).

    ``shapes`` has shape (n_nodes, 6, n_modes). With ``eigenvectors=False`` the file holds the eigenvalues
    and a static displacement table instead, i.e. no eigenvectors.
    """
    import contextlib
    import io
    import logging

    from postcapture.panels.nastran import _pynastran

    _, _, OP2 = _pynastran()
    import pyNastran
    from pyNastran.op2.tables.lama_eigenvalues.lama_objects import RealEigenvalues
    from pyNastran.op2.tables.oug.oug_displacements import RealDisplacementArray
    from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray

    class Writer(OP2):
        # pyNastran 1.3.x lists the LAMA table among the result tables it then refuses to write
        # (fixed in 1.4): hide it there, it is still written from `eigenvalues` first.
        def get_table_types(self):
            types = super().get_table_types()
            if pyNastran.__version__.startswith("1.3"):
                return [t for t in types if t != "eigenvalues"]
            return types

    log = logging.getLogger("tests.panels.op2")
    op2 = Writer(debug=False, log=log)
    op2.set_as_msc()
    n_nodes, _, n_modes = shapes.shape
    node_gridtype = np.column_stack([np.asarray(node_ids), np.ones(n_nodes)]).astype("int32")
    data = np.transpose(shapes, (2, 0, 1)).astype("float32")  # (n_modes, n_nodes, 6)
    omega2 = (2 * np.pi * np.asarray(frequencies_hz)) ** 2
    modes = np.arange(1, n_modes + 1, dtype="int32")
    lama = RealEigenvalues("", "LAMA", nmodes=n_modes)
    lama.mode[:] = modes
    lama.extraction_order[:] = modes
    lama.eigenvalues[:] = omega2
    lama.radians[:] = np.sqrt(omega2)
    lama.cycles[:] = frequencies_hz
    lama.generalized_mass[:] = 1.0
    lama.generalized_stiffness[:] = omega2
    op2.eigenvalues[""] = lama
    if eigenvectors:
        vec = RealEigenvectorArray.add_modal_case("OUGV1", node_gridtype, data, 1, modes, omega2,
                                                  np.asarray(frequencies_hz), is_sort1=True)
        vec.table_code = 7  # eigenvector, not displacement (add_modal_case keeps OUGV1's code 1)
        vec.data_code["table_code"] = 7
        op2.eigenvectors[1] = vec
    else:
        disp = RealDisplacementArray.add_static_case("OUGV1", node_gridtype, data[:1], 1, is_sort1=True)
        op2.displacements[1] = disp
    with contextlib.redirect_stdout(io.StringIO()):  # the 1.3.x writer prints its progress
        op2.write_op2(str(path), post=-1, endian=b"<")
