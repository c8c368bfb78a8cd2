"""synthesis.verify: the verifications drive their chains through closure.open_chain_poses.

Each one gives the pose (or centre) errors of the same chains hung from the ground of a
closure.Mechanism with every joint an input (the way they were verified before the bulk
path), keeps the chains' order (verify_open_chains groups them by joint letters), keeps
its messages, and is linear in the chains (no chunks).
"""
import numpy as np
import pytest

from closure import Mechanism, exp_se3
from synthesis import Line, SynthesisError
from synthesis.verify import (_frames_of, pose_errors, verify_chains, verify_driven,
                              verify_open_chains, verify_points)


def unit(rng, n=None):
    v = rng.normal(size=(3,) if n is None else (n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_line(rng):
    return Line(unit(rng), rng.normal(size=3))


def u_joint(rng):
    a = unit(rng)
    b = np.cross(a, unit(rng))
    return a, b / np.linalg.norm(b), rng.normal(size=3)


def mechanism_links(chains, P):
    """Per chain ``(types, frames (k, 4, 4), columns [(joint, coordinate, values (P,))],
    pitches)``: the link poses (P, V, k, 4, 4) of one Mechanism holding every chain."""
    m, cols = Mechanism(), []
    for v, (types, frames, drive, pitches) in enumerate(chains):
        names = ["ground"] + [f"v{v}L{j}" for j in range(len(types))]
        for j, t in enumerate(types):
            m.add_link(names[j + 1])
            m.add_joint(f"v{v}j{j}", t, names[j], names[j + 1], at=frames[j],
                        pitch=float(pitches[j]) if t == "H" else None)
        for j, i, x in drive:
            m.add_input(f"v{v}j{j}", i)
            cols.append(x)
    link = m.solve(np.stack(cols, 1), continuation=False).kinematics(twists=False).link
    return [link[:, [m.links.index(f"v{v}L{j}") for j in range(len(c[0]))]]
            for v, c in enumerate(chains)]


def u_frame(a, b, O):
    F = np.eye(4)
    F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = b, np.cross(a, b), a, O
    return F


@pytest.mark.parametrize("family", ["RUC", "URH", "CPC", "RHC", "PRR"])
def test_verify_driven_equals_the_mechanism(family):
    rng = np.random.default_rng(sum(map(ord, family)))
    P, V = 5, 12
    T = exp_se3(rng.normal(size=(P, 6)))
    chains, ref = [], []
    for _ in range(V):
        joints = [u_joint(rng) if t == "U" else random_line(rng) for t in family]
        vals = rng.normal(size=(P, 3, 2))
        pitches = rng.normal(size=3)
        chains.append((family, joints, vals, pitches))
        frames = [u_frame(*j) if t == "U" else _frames_of([j])[0] for t, j in zip(family, joints)]
        slots = {"R": (0,), "H": (0,), "P": (1,), "C": (0, 1), "U": (0, 1)}
        drive = [(j, i, vals[:, j, s]) for j, t in enumerate(family)
                 for i, s in enumerate(slots[t])]
        ref.append((family, frames, drive, pitches))
    bodies = np.stack([L[:, -1] for L in mechanism_links(ref, P)], 1)
    rot, pos = pose_errors(bodies, T[:, None], 2.5)
    assert np.allclose(verify_driven(chains, T, 2.5), np.maximum(rot.max(0), pos.max(0)),
                       rtol=0, atol=1e-12)


def test_verify_points_equals_the_mechanism_and_names_a_missing_pitch():
    rng = np.random.default_rng(4)
    P = 6
    T = exp_se3(rng.normal(size=(P, 6)))
    chains, ref = [], []
    for types in ["RR", "PR", "HC", "RH", "CP"]:
        lines = [random_line(rng), random_line(rng)]
        jv = rng.normal(size=(P, 2))
        pitches = rng.normal(size=2)
        centre = rng.normal(size=3)
        chains.append((types, lines, jv, centre, pitches))
        ref.append((types, _frames_of(lines), [(0, 0, jv[:, 0]), (1, 0, jv[:, 1])], pitches))
    got = verify_points(chains, T, 3.0)
    for v, L in enumerate(mechanism_links(ref, P)):
        B, O = L[:, 1], chains[v][3]
        err = np.linalg.norm(B[:, :3, :3] @ O + B[:, :3, 3] - (T[:, :3, :3] @ O + T[:, :3, 3]),
                             axis=1).max() / 3.0
        assert abs(got[v] - err) <= 1e-12
    bad = chains[:1] + [chains[3][:4]]
    with pytest.raises(SynthesisError, match=r"chains\[1\]: pitches: joint 2 is helical"):
        verify_points(bad, T, 3.0)


def test_verify_open_chains_keeps_the_order_of_mixed_chains():
    rng = np.random.default_rng(7)
    P = 4
    T = exp_se3(rng.normal(size=(P, 6)))
    chains = []
    for types in ["RC", "HPR", "RC", "C", "HPR", "PCHR"]:
        lines = [random_line(rng) for _ in types]
        pitches = [float(x) for x in rng.normal(size=len(types))]
        chains.append((types, lines, pitches, rng.normal(size=(P, len(types) + types.count("C")))))
    batch = verify_open_chains(chains, T, 2.0)
    one = [verify_open_chains([c], T, 2.0)[0] for c in chains]
    assert np.array_equal(batch, one)
    ref = [(t, _frames_of(ln), [(j, i, jv[:, c]) for c, (j, i) in enumerate(
        (j, i) for j, k in enumerate(t) for i in range(2 if k == "C" else 1))], p)
        for t, ln, p, jv in chains]
    for v, L in enumerate(mechanism_links(ref, P)):
        rot, pos = pose_errors(L[:, -1], T, 2.0)
        assert abs(batch[v] - max(rot.max(), pos.max())) <= 1e-12


def test_verify_chains_runs_thousands_of_chains_in_one_evaluation():
    """No chunks: 3000 chains at 6 positions in one call, each equal to its own call."""
    rng = np.random.default_rng(1)
    T = exp_se3(rng.normal(size=(6, 6)))
    lines = [random_line(rng) for _ in range(3)]
    chains = [("RPR", lines, rng.normal(size=(6, 3))) for _ in range(3000)]
    got = verify_chains(chains, T, 1.0)
    assert got.shape == (3000,)
    for v in (0, 1234, 2999):
        assert got[v] == verify_chains([chains[v]], T, 1.0)[0]


@pytest.mark.parametrize("types", ["RUR", "PCU", "CRH"])
def test_verify_chains_drives_the_first_coordinate_of_each_joint(types):
    """verify_chains takes one value per joint (a C or U joint, given by a Line, keeps its
    second coordinate at zero): as a Mechanism with coordinate 0 of each joint an input."""
    rng = np.random.default_rng(sum(map(ord, types)))
    P = 4
    T = exp_se3(rng.normal(size=(P, 6)))
    chains = [(types, [random_line(rng) for _ in types], rng.normal(size=(P, 3)))
              for _ in range(6)]
    if "H" in types:
        with pytest.raises(ValueError, match="pitch"):
            verify_chains(chains, T, 1.0)
        return
    got = verify_chains(chains, T, 1.0)
    ref = [(t, _frames_of(ln), [(j, 0, jv[:, j]) for j in range(3)], None)
           for t, ln, jv in chains]
    for v, L in enumerate(mechanism_links(ref, P)):
        rot, pos = pose_errors(L[:, -1], T, 1.0)
        assert abs(got[v] - max(rot.max(), pos.max())) <= 1e-12
