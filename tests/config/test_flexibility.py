"""Lumped panel stiffnesses for any segment count, from a piecewise-constant EI(s)."""

import numpy as np
import pytest

from postcapture.config.flexibility import ei_from_stiffness, refine_stiffness, stiffness_from_ei

K_ENVISAT = [8051.0, 47568.0, 15648.0, 6884.0, 8565.0]  # reference thesis, table 2


def test_refining_to_the_same_count_reproduces_the_table():
    np.testing.assert_allclose(refine_stiffness(K_ENVISAT, 14.0, 5), K_ENVISAT, rtol=1e-13)


def test_uniform_beam_gives_hencky_chain():
    # Uniform EI: the root hinge lumps half a cell (2 EI / l), the others a full cell (EI / l).
    EI, L, n = 2.0e5, 10.0, 8
    k = stiffness_from_ei([0.0, L], [EI], L, n)
    l = L / n
    np.testing.assert_allclose(k, [2 * EI / l] + [EI / l] * (n - 1), rtol=1e-13)


def test_series_compliance_is_conserved():
    # The total compliance sum(1/k) weighted by cell widths integrates ds/EI: refining keeps the
    # integral of 1/EI over the panel up to the half tip segment.
    L = 14.0
    edges, ei = ei_from_stiffness(K_ENVISAT, L)
    for n in (5, 7, 20, 50):
        k = refine_stiffness(K_ENVISAT, L, n)
        covered = (n - 0.5) * L / n
        expected = sum(
            (min(b, covered) - a) / e for a, b, e in zip(edges[:-1], edges[1:], ei) if a < covered
        )
        assert np.sum(1 / k) == pytest.approx(expected, rel=1e-12)
