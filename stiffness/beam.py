"""End stiffness of elastic beams (link compliance for the virtual-joint method)."""
from __future__ import annotations

import numpy as np

from .errors import StiffnessError
from .validate import number

__all__ = ["beam_compliance", "beam_stiffness", "beam_geometric_stiffness"]


def beam_compliance(length, *, E, G, area, Iy, Iz, J, shear_area_y=None,
                    shear_area_z=None) -> np.ndarray:
    """6x6 compliance of a straight cantilever's free end relative to its clamped end.

    The beam lies along the x axis of its end frame (from the clamped end to the free
    end), y and z are the principal axes of its section.  Euler–Bernoulli bending, plus
    Timoshenko shear deflection when shear areas are given.

    Parameters
    ----------
    length : float
        Beam length L (m).
    E, G : float
        Young's and shear moduli (Pa).
    area : float
        Cross-section area A (m²).
    Iy, Iz : float
        Second moments of the section about y and z (m⁴).
    J : float
        Torsion constant (m⁴).
    shear_area_y, shear_area_z : float, optional
        Effective shear areas κA for shear along y and z (m²); None: no shear deflection.

    Returns
    -------
    numpy.ndarray, shape (6, 6)
        ``Δ = C W`` at the free end, about its centre, in the end frame: ``W = (f, m)``
        (N, N·m), ``Δ = (δ, θ)`` (m, rad).  ``C[0, 0] = L/EA``, ``C[1, 1] = L³/3EIz``
        (+ ``L/G κA_y``), ``C[3, 3] = L/GJ``, ``C[1, 5] = L²/2EIz``, ``C[2, 4] = −L²/2EIy``.
    """
    L = number(length, "length", positive=True)
    E, G = number(E, "E", positive=True), number(G, "G", positive=True)
    A = number(area, "area", positive=True)
    Iy, Iz, J = (number(v, n, positive=True) for v, n in ((Iy, "Iy"), (Iz, "Iz"), (J, "J")))
    sy = 0.0 if shear_area_y is None else L / (G * number(shear_area_y, "shear_area_y",
                                                            positive=True))
    sz = 0.0 if shear_area_z is None else L / (G * number(shear_area_z, "shear_area_z",
                                                            positive=True))
    C = np.zeros((6, 6))
    C[0, 0] = L / (E * A)
    C[1, 1] = L**3 / (3 * E * Iz) + sy
    C[2, 2] = L**3 / (3 * E * Iy) + sz
    C[3, 3] = L / (G * J)
    C[4, 4] = L / (E * Iy)
    C[5, 5] = L / (E * Iz)
    C[1, 5] = C[5, 1] = L**2 / (2 * E * Iz)      # f_y bends about z: θz = f_y L² / 2EIz
    C[2, 4] = C[4, 2] = -L**2 / (2 * E * Iy)     # f_z bends about −y
    return C


def beam_stiffness(length, *, E, G, area, Iy, Iz, J, shear_area_y=None,
                   shear_area_z=None) -> np.ndarray:
    """6x6 stiffness of a cantilever's free end: the inverse of :func:`beam_compliance`
    (same arguments and frame).  ``K[0, 0] = EA/L``, ``K[3, 3] = GJ/L``, and without shear
    ``K[1, 1] = 12EIz/L³`` (end rotation held; with the end free to turn the force per
    deflection is ``1 / C[1, 1] = 3EIz/L³``)."""
    C = beam_compliance(length, E=E, G=G, area=area, Iy=Iy, Iz=Iz, J=J,
                        shear_area_y=shear_area_y, shear_area_z=shear_area_z)
    K = np.linalg.inv(C)
    if not np.all(np.isfinite(K)):                # pragma: no cover - positive inputs
        raise StiffnessError("length: the beam's compliance is singular")
    return 0.5 * (K + K.T)


def beam_geometric_stiffness(length, axial_force) -> np.ndarray:
    """The consistent geometric stiffness of a straight beam's free end (6x6, F's axes and
    order ``(δ, θ)``, x along the beam from the clamped end): the P-δ effect of the axial
    force ``N`` (N, tension positive) on bending, from the cubic (Hermite) deflection
    shapes of matrix structural analysis (Przemieniecki, *Theory of Matrix Structural
    Analysis*): ``N/L`` times ``6/5`` on the lateral deflections, ``2L²/15`` on the bending
    rotations and ``∓L/10`` coupling them.  The axial and torsional (Wagner) terms are
    not included.

    Parameters
    ----------
    length : float
        Beam length L (m).
    axial_force : float
        Axial force N (N), tension positive (compression lowers the bending stiffness).

    Returns
    -------
    numpy.ndarray, shape (6, 6)
        Blocks N/m, N/rad, N·m/rad, to add to :func:`beam_stiffness` under load.
    """
    L = number(length, "length", positive=True)
    N = number(axial_force, "axial_force")
    G = np.zeros((6, 6))
    G[1, 1] = G[2, 2] = 6 / (5 * L)
    G[4, 4] = G[5, 5] = 2 * L / 15
    G[1, 5] = G[5, 1] = -1 / 10                    # δy with θz (θz = dδy/dx)
    G[2, 4] = G[4, 2] = 1 / 10                     # δz with θy (θy = −dδz/dx)
    return N * G
