"""Lumped bending stiffnesses of a panel chain from a piecewise-constant bending stiffness EI(s).

A panel of length L is cut into N equal rigid segments of length l = L/N. Hinge i (i = 0..N-1) sits at
the root of segment i, at s_i = i l. It lumps the bending flexibility of the cell centred on it,
``[s_i - l/2, s_i + l/2]`` clipped to the panel (the root cell is ``[0, l/2]``), so that

    k_i = 1 / integral over cell_i of ds / EI(s).

For a uniform beam this gives k_0 = 2 EI/l and k_i = EI/l, the chain whose first cantilever frequency
converges to Euler-Bernoulli's with order 2 in 1/N (the tests assert it). Segment-length cells only
converge with order 1.

Conversely, N given stiffnesses define a piecewise-constant EI on the N cells (EI_i = k_i |cell_i|; the
last piece extends to the tip), from which any other N is derived. For the reference's 5-segment
tables this reproduces the table exactly at N = 5.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cell_edges", "ei_from_stiffness", "stiffness_from_ei", "refine_stiffness"]


def cell_edges(length: float, n: int) -> np.ndarray:
    """Edges of the n hinge cells along the panel, shape (n + 1,); the last edge is the tip."""
    l = length / n
    edges = np.concatenate([[0.0], (np.arange(n) + 0.5) * l])
    edges[-1] = length  # the tip half-segment carries no moment: fold it into the last piece
    return edges


def ei_from_stiffness(k, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-constant EI(s) (N m^2) implied by hinge stiffnesses ``k`` (N m/rad).

    Returns
    -------
    edges : ndarray, shape (n + 1,)
        Piece boundaries along the panel (m), 0 at the root, ``length`` at the tip.
    ei : ndarray, shape (n,)
        Bending stiffness on each piece (N m^2).
    """
    k = np.asarray(k, dtype=float)
    n = k.size
    l = length / n
    widths = np.full(n, l)
    widths[0] = 0.5 * l
    return cell_edges(length, n), k * widths


def stiffness_from_ei(edges, ei, length: float, n: int) -> np.ndarray:
    """Hinge stiffnesses (N m/rad) of an n-segment chain for a piecewise-constant EI(s)."""
    edges = np.asarray(edges, dtype=float)
    ei = np.asarray(ei, dtype=float)
    l = length / n
    lo = np.concatenate([[0.0], (np.arange(1, n) - 0.5) * l])
    hi = (np.arange(n) + 0.5) * l
    compliance = np.zeros(n)
    for a, b, e in zip(edges[:-1], edges[1:], ei):
        overlap = np.clip(np.minimum(hi, b) - np.maximum(lo, a), 0.0, None)
        compliance += overlap / e
    return 1.0 / compliance


def refine_stiffness(k_ref, length: float, n: int) -> np.ndarray:
    """Stiffnesses for n segments from the stiffnesses ``k_ref`` of another segmentation."""
    edges, ei = ei_from_stiffness(k_ref, length)
    return stiffness_from_ei(edges, ei, length, n)
