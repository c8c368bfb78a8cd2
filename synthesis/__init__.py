"""synthesis — finite-position synthesis of spatial dyads from screw displacements (seed 001).

Main names
----------
Screw               finite screw displacement: axis, point, angle (rad), slide; ``matrix()``,
                    ``from_matrix``, ``from_degrees``, composition, ``relative_screw``
Line                a joint axis: unit direction and canonical point
rr_links            the two RR links through three positions (motion-polynomial algebra)
rotation_axis_between  the pure rotation carrying an axis between two positions
rs_links            RS links through four positions (a one-parameter family, traced)
helical_links       HH, RH, HR (and RR) links of given pitches through three positions
hh_links_free_pitch the HH link with both pitches free, for a chosen fixed direction
rc_links, cr_links  RC/HC and CR/CH links through three positions for a chosen fixed direction
cc_links            CC links through 3 (fixed axis chosen), 4 (azimuth or direction, and point
                    chosen) or 5 positions (all solutions); cc_directions: the admissible
                    fixed directions through 4 positions at an azimuth
pr_links, rp_links  PR and RP links through three positions turned about one direction (the
                    infinite-pitch limit of HR, RH); pc_links, cp_links for a chosen
                    slide direction
BinaryLink          a binary link of R, H, C joints: axes, pitches, joint values, residual
verify_chains, verify_points, verify_links   engine verification (synthesis.verify; not in __all__)
enumerate_dyads     every variant of a family of Kharatyan's Table 3 (41 of its 51 families,
                    and the reverses of those by kinematic inversion) as one table layout
                    verified by the engine, free parameters as keyword choices
                    (synthesis.decompose, .sphere_families, .sphere_middle, .hooke_families)
families            Kharatyan's Table 3 as data, with the arrangements implemented
implemented_families, transition_joint, two_position_link   the family engine's parts
                    (synthesis.dyads, .transition, .twopos; not in __all__)
invert_chain, inverse_screws   kinematic inversion of a synthesised chain
"""
from .binary import BinaryLink
from .cylindric import cc_direction_residual, cc_directions, cc_links, cr_links, rc_links
from .dyads import DYAD_COLUMNS, enumerate_dyads, implemented_families, rrr_dyads  # noqa: F401
from .errors import SynthesisError
from .families import JOINT_LETTERS, families
from .inversion import invert_chain, inverse_screws
from .rr import RRLink, rotation_axis_between, rr_links
from .rs import RSLink, rs_links
from .screw import Line, Screw, relative_screw
from .helical import helical_links, hh_links_free_pitch
from .prismatic import cp_links, pc_links, pr_links, rp_links
from .transition import transition_joint  # noqa: F401
from .twopos import two_position_link  # noqa: F401
from .verify import (chain_mechanism, verify_chain, verify_chains, verify_links,  # noqa: F401
                     verify_points)

__all__ = ["Screw", "Line", "relative_screw", "RRLink", "rr_links", "rotation_axis_between",
           "enumerate_dyads", "rrr_dyads", "rs_links", "RSLink", "verify_chain", "chain_mechanism", "DYAD_COLUMNS",
           "families", "JOINT_LETTERS", "invert_chain", "inverse_screws", "SynthesisError",
           "BinaryLink", "helical_links", "hh_links_free_pitch", "rc_links", "cr_links", "cc_links", "cc_direction_residual",
           "cc_directions", "pr_links", "rp_links", "pc_links", "cp_links"]

#: importable names that are not in __all__ (the engine's parts; pyflakes sees them used)
_NOT_IN_ALL = (implemented_families, transition_joint, two_position_link, verify_chains,
               verify_links, verify_points)
