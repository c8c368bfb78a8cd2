"""Batched transition joints (synthesis.transition.transition_joints): the same joints and
the same reasons as the one-problem form for every problem of a batch, the chains they
build reach the remaining positions, and bad input is named; the batched RC/CR links of a
direction grid (synthesis.cylindric.fixed_direction_links) are rc_links/cr_links'."""
import numpy as np
import pytest

from synthesis import Line, Screw, SynthesisError
from synthesis.binary import _screw_matrix
from synthesis.cylindric import cr_links, fixed_direction_links, rc_links
from synthesis.transition import transition_joint, transition_joints


def _unit(v):
    return v / np.linalg.norm(v)


def _problems(rng, kind, y_kind, n):
    """n problems: J3's axis and displacements D (n, k, 4, 4), a third of them built from
    a known transition joint (exactly solvable), some degenerate (D about J3's own axis)."""
    k = 2 if kind == "C" else 1
    lines = [Line(_unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(n)]
    u = np.array([ln.direction for ln in lines])
    p = np.array([ln.point for ln in lines])
    D = np.empty((n, k, 4, 4))
    for i in range(n):
        for j in range(k):
            if i % 5 == 4:                                   # on J3's own motion
                D[i, j] = _screw_matrix(u[i], p[i], rng.uniform(-2, 2), 0.0)
            else:
                t = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
                D[i, j] = _screw_matrix(t.direction, t.point, rng.uniform(-2, 2),
                                        rng.uniform(-1, 1) if kind == "C" else 0.0) @ \
                    np.linalg.inv(_screw_matrix(u[i], p[i], rng.uniform(-2, 2),
                                                rng.uniform(-1, 1) if y_kind in "CP" else 0.0))
    return u, p, D


@pytest.mark.parametrize("kind, y_kind", [("R", "R"), ("R", "P"), ("R", "H"), ("R", "C"),
                                          ("C", "C")])
def test_batch_equals_one_problem_at_a_time(kind, y_kind):
    rng = np.random.default_rng(len(kind + y_kind) + ord(y_kind))
    n = 25
    u, p, D = _problems(rng, kind, y_kind, n)
    angle = rng.uniform(-2, 2, n) if (kind, y_kind) == ("R", "C") else None
    tr = transition_joints(kind, y_kind, u, p, 0.3, D, 2.0, angle=angle)
    assert tr.error.shape == (n,) and np.all(np.diff(tr.owner) >= 0)
    for i in range(n):
        try:
            one = transition_joint(kind, y_kind, Line._exact(u[i], p[i]), 0.3, D[i], 2.0,
                                   angle=None if angle is None else angle[i])
        except SynthesisError as e:
            assert tr.error[i] == str(e) and not np.any(tr.owner == i)
            continue
        assert tr.error[i] == ""
        rows = np.flatnonzero(tr.owner == i)
        assert len(rows) == len(one)
        for r, t in zip(rows, one):
            np.testing.assert_array_equal(tr.direction[r], t.line.direction)
            np.testing.assert_array_equal(tr.point[r], t.line.point)
            np.testing.assert_array_equal(tr.psi[r], t.psi)
            np.testing.assert_array_equal(tr.delta[r], t.delta)
            # the transition joint and J3 carry the transition position to the remaining
            # ones: D_l = X(ψ_l) · Y(Δ_l)
            for j in range(D.shape[1]):
                X = _screw_matrix(t.line.direction, t.line.point, t.psi[j, 0], t.psi[j, 1])
                sl = 0.3 * t.delta[j, 0] if y_kind == "H" else t.delta[j, 1]
                Y = _screw_matrix(u[i], p[i], 0.0 if y_kind == "P" else t.delta[j, 0], sl)
                np.testing.assert_allclose(X @ Y, D[i, j], atol=1e-8)


def test_transition_joints_names_bad_input():
    D = np.tile(np.eye(4), (2, 1, 1, 1))
    with pytest.raises(SynthesisError, match="not implemented"):
        transition_joints("C", "R", np.zeros((2, 3)), np.zeros((2, 3)), 0.0, D, 1.0)
    with pytest.raises(SynthesisError, match="^D:"):
        transition_joints("R", "R", np.zeros((2, 3)), np.zeros((2, 3)), 0.0, D[:, 0], 1.0)
    with pytest.raises(SynthesisError, match="takes 2 remaining"):
        transition_joints("C", "C", np.zeros((2, 3)), np.zeros((2, 3)), 0.0, D, 1.0)
    with pytest.raises(SynthesisError, match="^direction, point:"):
        transition_joints("R", "R", np.zeros((3, 3)), np.zeros((2, 3)), 0.0, D, 1.0)
    with pytest.raises(SynthesisError, match="^y_pitch:"):
        transition_joints("R", "H", np.zeros((2, 3)), np.zeros((2, 3)), [0.1] * 3, D, 1.0)
    with pytest.raises(SynthesisError, match="^angle: required"):
        transition_joints("R", "C", np.zeros((2, 3)), np.zeros((2, 3)), 0.0, D, 1.0)
    empty = transition_joints("R", "R", np.zeros((0, 3)), np.zeros((0, 3)), 0.0,
                              np.zeros((0, 1, 4, 4)), 1.0)
    assert empty.owner.shape == (0,) and empty.psi.shape == (0, 1, 2)


@pytest.mark.parametrize("kinds, pitch", [("RC", 0.0), ("RC", 0.4), ("CR", 0.0), ("CR", -0.3)])
def test_fixed_direction_grid_equals_one_direction_at_a_time(kinds, pitch):
    rng = np.random.default_rng(7)
    s12 = Screw(_unit(rng.normal(size=3)), rng.normal(size=3), 1.1, 0.3)
    s13 = Screw(_unit(rng.normal(size=3)), rng.normal(size=3), -0.7, -0.2)
    G = np.array([_unit(rng.normal(size=3)) for _ in range(6)])
    G[2] = s12.axis                                      # a degenerate direction
    res = fixed_direction_links(kinds, s12, s13, G, pitch)
    for g, r in zip(G, res):
        try:
            one = (rc_links(s12, s13, g, fixed_pitch=pitch) if kinds == "RC" else
                   cr_links(s12, s13, g, moving_pitch=pitch))
        except SynthesisError as e:
            assert isinstance(r, SynthesisError) and str(r) == str(e)
            continue
        (a,), (b,) = r, one
        assert a.types == b.types
        for x in ("fixed_axis", "moving_axis"):
            np.testing.assert_allclose(getattr(a, x).direction, getattr(b, x).direction)
            np.testing.assert_allclose(getattr(a, x).point, getattr(b, x).point)
        np.testing.assert_allclose(a.residual, b.residual, atol=1e-15)
        np.testing.assert_array_equal(a.parameters["fixed_direction"], g)
    with pytest.raises(SynthesisError, match="^kinds:"):
        fixed_direction_links("CC", s12, s13, G)
