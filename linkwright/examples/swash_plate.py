"""Wobble-plate (swash-plate) drive of a cutter bar — seed 000, Fig. 2.

The input shaft (R about x) carries a journal inclined by ``beta`` on which the
wobble plate turns (R).  A Hooke joint (U) at the journal centre ties the plate
to the frame, so the plate nutates without spinning.  The plate arm drives, by
a rod with a ball end (S) at the arm and a Hooke joint (U) at the other end,
a lever that swings about a vertical axis (R) and moves the knife.

Two independent loops (ground–shaft–plate–U and plate–rod–lever–ground), one
degree of freedom.  Run it to print the sweep table over one shaft turn::

    python -m linkwright.examples.swash_plate
"""
from __future__ import annotations

import numpy as np

from closure import Mechanism, frame_from_points, point_analogs, translation

BETA = np.radians(15.0)          # journal inclination (rad)
ARM = np.array([0.0, 0.0, 0.25])         # ball centre on the plate arm (m)
ROD_END = np.array([0.40, 0.0, 0.25])    # rod's Hooke joint at the lever (m)
LEVER_AXIS = np.array([0.40, 0.15, 0.0])  # a point on the lever's vertical axis (m)


def build() -> Mechanism:
    """The wobble-plate drive at its assembly pose (shaft angle 0)."""
    m = Mechanism(["shaft", "plate", "rod", "lever"])
    j = np.array([np.cos(BETA), 0.0, np.sin(BETA)])
    m.add_joint("shaft", "R", "ground", "shaft", at=frame_from_points([0, 0, 0], [0, 1, 0], [1, 0, 0]))
    m.add_joint("journal", "R", "shaft", "plate", at=frame_from_points([0, 0, 0], [0, 1, 0], j))
    # Hooke joint: Z along the frame's vertical pin, X along the plate's pin (y)
    m.add_joint("antispin", "U", "ground", "plate",
                at=frame_from_points([0, 0, 0], [0, 1, 0], [0, 0, 1]))
    m.add_joint("ball", "S", "plate", "rod", at=translation(ARM))
    m.add_joint("rod_end", "U", "rod", "lever",
                at=frame_from_points(ROD_END, ROD_END + [0, 0, 1], ROD_END + [0, 1, 0]))
    m.add_joint("lever", "R", "lever", "ground",
                at=frame_from_points(LEVER_AXIS, LEVER_AXIS + [1, 0, 0], LEVER_AXIS + [0, 0, 1]))
    m.add_input("shaft")
    return m


def knife_point() -> np.ndarray:
    """The lever point that drives the knife (the rod end), ground coordinates at assembly."""
    return ROD_END.copy()


def main() -> None:
    m = build()
    angles = np.linspace(0.0, 2 * np.pi, 25)
    df, poses = m.sweep(angles, return_pose=True)
    x, d1, d2 = point_analogs(m, poses, "lever", knife_point())
    df["knife_x"] = x[:, 0]
    df["knife_dx/dshaft"] = d1[:, 0, 0]
    df["knife_d2x/dshaft2"] = d2[:, 0, 0, 0]
    cols = ["input:shaft", "journal", "antispin.phi", "antispin.theta", "lever",
            "knife_x", "knife_dx/dshaft", "knife_d2x/dshaft2", "residual", "condition", "status"]
    print(f"wobble-plate drive: {m.n_loops} loops, mobility {m.mobility}")
    with np.printoptions(precision=4):
        print(df[cols].to_string(index=False, float_format=lambda v: f"{v: .6g}"))


if __name__ == "__main__":
    main()
