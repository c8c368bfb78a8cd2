"""synthesis — finite-position synthesis of spatial dyads from screw displacements (seed 001).

Main names
----------
Screw               finite screw displacement: axis, point, angle (rad), slide; ``matrix()``,
                    ``from_matrix``, ``from_degrees``, composition, ``relative_screw``
Line                a joint axis: unit direction and canonical point
rr_links            the two RR links through three positions (motion-polynomial algebra)
rotation_axis_between  the pure rotation carrying an axis between two positions
rs_links            RS links through four positions (a one-parameter family, traced)
enumerate_dyads     every variant of a family as a DataFrame verified by the engine:
                    RRR by four positions (36), RRS by six, PRS by five
families            seed 001's Table 3 as data, with what is implemented
invert_chain, inverse_screws   kinematic inversion of a synthesised chain
"""
from .dyads import DYAD_COLUMNS, chain_mechanism, enumerate_dyads, rrr_dyads, verify_chain
from .errors import SynthesisError
from .families import JOINT_LETTERS, families
from .inversion import invert_chain, inverse_screws
from .rr import RRLink, rotation_axis_between, rr_links
from .rs import RSLink, rs_links
from .screw import Line, Screw, relative_screw

__all__ = ["Screw", "Line", "relative_screw", "RRLink", "rr_links", "rotation_axis_between",
           "enumerate_dyads", "rrr_dyads", "rs_links", "RSLink", "verify_chain", "chain_mechanism", "DYAD_COLUMNS",
           "families", "JOINT_LETTERS", "invert_chain", "inverse_screws", "SynthesisError"]
