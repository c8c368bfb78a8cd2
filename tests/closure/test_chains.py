"""closure.open_chain_poses: open chains driven at every joint, in bulk.

The poses are those of closure.Mechanism (the chains hung from the ground, every
coordinate an input, solved and evaluated by the engine) to 1e-12 for every joint kind;
bad input raises MechanismError naming the argument; a batch equals its chains one by
one, and a rigid motion of the frames (far from the origin) moves the poses with it.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from closure import Mechanism, MechanismError, exp_se3, inverse, open_chain_poses
from closure.joints import JOINT_KINDS

FAST = settings(max_examples=25, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def random_chains(rng, V, k, P, kinds=None, scale=1.0):
    """V chains of k joints (random kinds from RPCHU unless given), frames, values (P, V,
    k, 2) and pitches (V, k)."""
    if kinds is None:
        kinds = ["".join(rng.choice(list("RPCHU"), k)) for _ in range(V)]
    F = exp_se3(np.concatenate([scale * rng.normal(size=(V, k, 3)),
                                rng.normal(size=(V, k, 3))], -1))
    q = rng.normal(size=(P, V, k, 2))
    q[..., 0] *= np.where(np.array([list(s) for s in np.broadcast_to(kinds, V)]) == "P",
                          scale, 1.0)
    h = scale * rng.normal(size=(V, k))
    return kinds, F, q, h


def engine_poses(kinds, F, q, h):
    """The same chains hung from the ground of one Mechanism, every coordinate an input."""
    P, V, k = q.shape[:3]
    kinds = np.broadcast_to(kinds, V)
    m, cols = Mechanism(), []
    for v in range(V):
        names = ["ground"] + [f"v{v}L{j}" for j in range(k)]
        for j, t in enumerate(kinds[v]):
            m.add_link(names[j + 1])
            m.add_joint(f"v{v}j{j}", t, names[j], names[j + 1], at=F[v, j],
                        pitch=h[v, j] if t == "H" else None)
            for i in range(JOINT_KINDS[t]):
                m.add_input(f"v{v}j{j}", i)
                cols.append(q[:, v, j, i])
    link = m.solve(np.stack(cols, 1), continuation=False).kinematics(twists=False).link
    return link[:, [m.links.index(f"v{v}L{j}") for v in range(V) for j in range(k)]] \
        .reshape(P, V, k, 4, 4)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_equals_the_mechanism_for_every_kind(k):
    rng = np.random.default_rng(k)
    kinds, F, q, h = random_chains(rng, 40, k, 5)
    got = open_chain_poses(kinds, F, q, h)
    assert got.shape == (5, 40, k, 4, 4)
    assert np.abs(got - engine_poses(kinds, F, q, h)).max() <= 1e-12


@pytest.mark.parametrize("kinds", ["R", "P", "C", "H", "U", "RUC", "CPC", "UHU", "RRR"])
def test_shared_kinds_equal_the_mechanism(kinds):
    rng = np.random.default_rng(len(kinds))
    _, F, q, h = random_chains(rng, 7, len(kinds), 4, kinds=kinds, scale=3.0)
    got = open_chain_poses(kinds, F, q, h)
    assert np.abs(got - engine_poses(kinds, F, q, h)).max() <= 1e-12 * 3.0
    assert np.array_equal(got, open_chain_poses([kinds] * 7, F, q, h))


def test_zero_coordinates_give_identities_and_one_coordinate_values():
    rng = np.random.default_rng(5)
    kinds, F, q, h = random_chains(rng, 6, 3, 2, kinds="RUC")
    assert np.allclose(open_chain_poses(kinds, F, 0 * q, h), np.eye(4), atol=1e-12)
    _, F, q, h = random_chains(rng, 6, 3, 2, kinds="RPH")
    assert np.array_equal(open_chain_poses("RPH", F, q[..., 0], h),
                          open_chain_poses("RPH", F, q, h))


def test_empty_batches():
    assert open_chain_poses("RC", np.zeros((0, 2, 4, 4)), np.zeros((3, 0, 2, 2))).shape == \
        (3, 0, 2, 4, 4)
    F = np.broadcast_to(np.eye(4), (2, 2, 4, 4))
    assert open_chain_poses("RC", F, np.zeros((0, 2, 2, 2))).shape == (0, 2, 2, 4, 4)


F2 = np.broadcast_to(np.eye(4), (2, 3, 4, 4))
Q2 = np.zeros((4, 2, 3, 2))
NOT_RIGID = F2.copy()
NOT_RIGID[0, 1, :3, :3] *= 1.01
NAN_Q = Q2.copy()
NAN_Q[1, 1, 1, 0] = np.nan


@pytest.mark.parametrize("args, name", [
    (("RSR", F2, Q2), "kinds"), (("RXR", F2, Q2), "kinds"), (("", F2, Q2), "kinds"),
    ((None, F2, Q2), "kinds"), ((3, F2, Q2), "kinds"), ((["RRR", "RR"], F2, Q2), "kinds"),
    ((["RRR", 5], F2, Q2), "kinds"), (([], F2, Q2), "kinds"),
    ((["RRR"] * 3, F2, Q2), "frames"), (("RR", F2, Q2), "frames"),
    (("RRR", F2[0], Q2), "frames"), (("RRR", NOT_RIGID, Q2), "frames"),
    (("RRR", F2 * np.nan, Q2), "frames"), (("RRR", "F", Q2), "frames"),
    (("RRR", F2, Q2[:, :1]), "values"), (("RRR", F2, Q2[..., :1]), "values"),
    (("RCR", F2, Q2[..., 0]), "values"), (("RRR", F2, NAN_Q), "values"),
    (("RRR", F2, "q"), "values"), (("RRR", F2, Q2[0]), "values"),
    (("RHR", F2, Q2), "pitches"), (("RHR", F2, Q2, [1.0, np.nan, 1.0]), "pitches"),
    (("RRR", F2, Q2, np.ones(4)), "pitches"), (("RRR", F2, Q2, "h"), "pitches"),
])
def test_bad_input_names_the_argument(args, name):
    with pytest.raises(MechanismError, match=f"^{name}:"):
        open_chain_poses(*args)


def test_non_helical_pitches_are_not_read():
    rng = np.random.default_rng(2)
    _, F, q, _ = random_chains(rng, 3, 3, 2, kinds="RHP")
    h = np.full((3, 3), np.nan)
    h[:, 1], h[:, 2] = 0.25, np.inf                # a P joint's pitch: infinite
    q[0] = 0.0                                      # (0 · inf would be NaN)
    with np.errstate(all="raise"):
        assert np.isfinite(open_chain_poses("RHP", F, q, h)).all()


@FAST
@given(seed=st.integers(0, 2**32 - 1), V=st.integers(1, 12), k=st.integers(1, 3),
       P=st.integers(1, 5))
def test_a_batch_equals_its_chains_one_by_one(seed, V, k, P):
    kinds, F, q, h = random_chains(np.random.default_rng(seed), V, k, P)
    batch = open_chain_poses(kinds, F, q, h)
    for v in range(V):
        one = open_chain_poses(kinds[v], F[v:v + 1], q[:, v:v + 1], h[v:v + 1])
        assert np.abs(batch[:, v:v + 1] - one).max() <= 1e-15


@FAST
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 3),
       far=st.sampled_from([1.0, 1e3, 1e5]))
def test_rigid_motion_far_from_the_origin_moves_the_poses(seed, k, far):
    """Frames G·F give the poses G·L·G⁻¹ (G a rigid motion ``far`` from the origin)."""
    rng = np.random.default_rng(seed)
    kinds, F, q, h = random_chains(rng, 8, k, 4)
    G = exp_se3(np.r_[far * rng.normal(size=3), rng.normal(size=3)])
    moved = open_chain_poses(kinds, G @ F, q, h)
    back = inverse(G) @ moved @ G
    assert np.abs(back - open_chain_poses(kinds, F, q, h)).max() <= 1e-13 * (1 + far)


def test_unvalidated_frames_are_multiplied_as_given():
    """validate=False (frames a program built as exact rotations) skips the rigidity check
    only: the poses are the same products."""
    rng = np.random.default_rng(9)
    kinds, F, q, h = random_chains(rng, 5, 3, 3, kinds="CUH")
    assert np.array_equal(open_chain_poses(kinds, F, q, h, validate=False),
                          open_chain_poses(kinds, F, q, h))
    skewed = F.copy()
    skewed[:, :, :3, :3] *= 1.01
    open_chain_poses(kinds, skewed, q, h, validate=False)
    with pytest.raises(MechanismError, match="^frames:"):
        open_chain_poses(kinds, skewed, q, h)
