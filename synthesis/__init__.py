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
rs_links_at, sr_links   RS and SR links through four positions at an explicit azimuth of the
                    axis (every link on that great circle: a univariate condition's roots)
ps_links, sp_links  PS and SP links through three positions at an azimuth of the slide
hs_links, sh_links  HS and SH links (pitch given) through four positions at an azimuth
ur_links, up_links, uh_links, uc_links   links with a universal joint (С₂) in the ground;
                    u_directions: every universal joint whose link takes four orientations
ph_links, hp_links  PH and HP links through two positions for a chosen slide direction
task_frame, azimuth_of  the task's reference frame of the azimuths, and a direction's azimuth
BinaryLink          a binary link of R, H, C, P, S, U joints: axes, pitches, joint values, residual
complete_dyads      every real solution at N_max: RR (3 positions), CC (5), SS and TS (7),
                    with the count over the complex numbers (eigenvalue methods)
least_squares_dyads RR, CC, SS through more positions than N_max, by least squares from
                    every exact solution of every N_max-subset
verify_chains, verify_points, verify_links   engine verification (synthesis.verify; not in __all__)
enumerate_dyads     every variant of a family of Kharatyan's Table 3 (47 of its 51 families,
                    and the reverses of those by kinematic inversion) as one table layout
                    verified by the engine, free parameters as keyword choices
                    (synthesis.decompose, .sphere_families, .sphere_middle, .hooke_families)
families            Kharatyan's Table 3 as data, with the arrangements implemented
implemented_families  how each family is built (direct, by inversion)
transition_joint, two_position_link   the family engine's parts
                    (synthesis.transition, .twopos; not in __all__)
invert_chain, inverse_screws   kinematic inversion of a synthesised chain
assemble, Assembly  two or more links sharing ground and body closed into an engine
                    mechanism, swept from position 1: order, branch and dead-point
                    defects, transmission quality (synthesis.assemble)
chain_tolerance     Monte Carlo manufacturing tolerances of a chain on the engine against
                    the first-order prediction (synthesis.tolerance)
assemble_table, link_from_row   every combination of a solution table's links assembled,
                    ranked: no defects first, then by transmission
"""
from .assemble import Assembly, assemble, assemble_table, link_from_row
from .tolerance import ToleranceResult, chain_tolerance
from .binary import BinaryLink
from .cylindric import cc_direction_residual, cc_directions, cc_links, cr_links, rc_links
from .complete import complete_dyads, least_squares_dyads
from .dyads import DYAD_COLUMNS, enumerate_dyads, implemented_families, rrr_dyads
from .hooke import u_directions, uc_links, uh_links, up_links, ur_links
from .errors import SynthesisError
from .families import JOINT_LETTERS, families
from .inversion import invert_chain, inverse_screws
from .rr import RRLink, rotation_axis_between, rr_links
from .rs import RSLink, rs_links
from .screw import Line, Screw, relative_screw
from .helical import helical_links, hh_links_free_pitch
from .prismatic import cp_links, hp_links, pc_links, ph_links, pr_links, rp_links
from .spherical import (azimuth_of, hs_links, ps_links, rs_links_at, sh_links, sp_links, sr_links,
                        task_frame)
from .transition import transition_joint  # noqa: F401
from .twopos import two_position_link  # noqa: F401
from .verify import (chain_mechanism, verify_chain, verify_chains, verify_links,  # noqa: F401
                     verify_points)

__all__ = ["Screw", "Line", "relative_screw", "RRLink", "rr_links", "rotation_axis_between",
           "enumerate_dyads", "rrr_dyads", "rs_links", "RSLink", "verify_chain", "chain_mechanism", "DYAD_COLUMNS",
           "families", "JOINT_LETTERS", "invert_chain", "inverse_screws", "SynthesisError",
           "BinaryLink", "helical_links", "hh_links_free_pitch", "rc_links", "cr_links", "cc_links", "cc_direction_residual",
           "cc_directions", "pr_links", "rp_links", "pc_links", "cp_links", "rs_links_at",
           "sr_links", "ps_links", "sp_links", "hs_links", "sh_links", "ur_links", "up_links",
           "uh_links", "uc_links", "u_directions", "ph_links", "hp_links", "task_frame",
           "azimuth_of", "complete_dyads", "least_squares_dyads", "implemented_families",
           "assemble", "Assembly", "assemble_table", "link_from_row",
           "chain_tolerance", "ToleranceResult"]

#: importable names that are not in __all__ (the engine's parts; pyflakes sees them used)
_NOT_IN_ALL = (transition_joint, two_position_link, verify_chains,
               verify_links, verify_points)
