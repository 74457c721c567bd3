"""The force law against hand computations, and the compiled kernel against the reference."""

import numpy as np
import pytest

from adapter.body.springs import momentum_rate, network_from_edges, region_constants, smooth_step


def _three_nodes(form):
    # nodes 0-1-2 on a line, edges (0,1) and (1,2), rest lengths 1 and 2
    X0 = np.array([[0.0, 0, 0], [1.0, 0, 0], [3.0, 0, 0]])
    k = np.array([10.0, 20.0, 40.0])
    return X0, network_from_edges(X0, [[0, 1], [1, 2]], k, mu=0.5, nu=0.1, form=form)


@pytest.mark.parametrize("kernel", ["forces", "forces_numpy"])
def test_paper_force_by_hand(kernel):
    X0, net = _three_nodes("paper")
    X = X0.copy()
    X[2, 0] = 3.5  # edge (1,2) stretched from 2 to 2.5
    X[0, 1] = 0.3  # node 0 lifted: edge (0,1) length sqrt(1.09)
    V = np.array([[0.0, 1.0, 0], [0.0, 0, 0], [2.0, 0, 0]])
    F = getattr(net, kernel)(X, V)
    l01 = np.sqrt(1.09)
    d01 = X[1] - X[0]
    # node 0: neighbour 1 with k_1 = 20
    f0 = 0.5 * (V[1] - V[0]) + 20 * d01 * (1 - 1 / l01) - 0.1 * V[0]
    # node 1: neighbours 0 (k_0 = 10) and 2 (k_2 = 40)
    d12 = X[2] - X[1]
    f1 = (0.5 * (V[0] - V[1]) + 10 * (-d01) * (1 - 1 / l01)
          + 0.5 * (V[2] - V[1]) + 40 * d12 * (1 - 2 / 2.5) - 0.1 * V[1])
    # node 2: neighbour 1 with k_1 = 20
    f2 = 0.5 * (V[1] - V[2]) + 20 * (-d12) * (1 - 2 / 2.5) - 0.1 * V[2]
    np.testing.assert_allclose(F, [f0, f1, f2], rtol=1e-13, atol=1e-13)


def test_symmetric_form_conserves_momentum_and_paper_form_does_not():
    X0, paper = _three_nodes("paper")
    _, sym = _three_nodes("symmetric")
    X = X0 + np.array([[0, 0.2, 0], [0.1, 0, 0], [0.4, 0, 0.1]])
    V = np.zeros_like(X)
    assert np.allclose(sym.forces(X, V).sum(axis=0), 0, atol=1e-14)
    imbalance = paper.forces(X, V).sum(axis=0)
    assert np.linalg.norm(imbalance) > 1e-3
    np.testing.assert_allclose(momentum_rate(paper, X, V), imbalance, atol=1e-13)
    np.testing.assert_allclose(momentum_rate(sym, X, V), 0, atol=0)


def test_compiled_kernel_matches_reference_on_the_whale(smoke_animator):
    net = smoke_animator.network
    rng = np.random.default_rng(0)
    X = smoke_animator.rest + 0.05 * rng.normal(size=smoke_animator.rest.shape)
    V = rng.normal(size=X.shape)
    np.testing.assert_allclose(net.forces(X, V), net.forces_numpy(X, V), rtol=1e-11, atol=1e-10)


def test_region_constants_high_in_pivot_low_at_ends():
    s = np.array([0.0, 0.1, 0.4, 0.45, 0.8, 0.95])
    k = region_constants(s, head_end=0.27, tail_start=0.55, k_head=40, k_pivot=400, k_tail=20,
                         transition=0.05)
    np.testing.assert_allclose(k, [40, 40, 400, 400, 20, 20])
    mid = region_constants(np.array([0.27]), 0.27, 0.55, 40, 400, 20, 0.05)
    assert 40 < mid[0] < 400


def test_default_form_is_the_papers_and_a_symmetric_network_has_no_momentum_rate():
    X0 = np.array([[0.0, 0, 0], [1.0, 0, 0], [3.0, 0, 0]])
    k = np.array([10.0, 20.0, 40.0])
    default = network_from_edges(X0, [[0, 1], [1, 2]], k, mu=0.5, nu=0.1)
    _, paper = _three_nodes("paper")
    X = X0 + np.array([[0, 0.2, 0], [0.1, 0, 0], [0.4, 0, 0.1]])
    V = np.zeros_like(X)
    np.testing.assert_array_equal(default.forces(X, V), paper.forces(X, V))
    np.testing.assert_array_equal(default.forces_numpy(X, V), paper.forces_numpy(X, V))
    _, sym = _three_nodes("symmetric")
    assert momentum_rate(sym, X, V).tolist() == [0.0, 0.0, 0.0]


def test_smooth_step_is_the_cubic_smoothstep():
    # 3 t^2 - 2 t^3 with t = (x - edge) / width + 1/2, clipped to [0, 1]
    x = np.array([-1.0, 0.375, 0.5, 0.625, 0.75, 2.0])
    expected = [0.0, 0.15625, 0.5, 0.84375, 1.0, 1.0]
    np.testing.assert_allclose(smooth_step(x, 0.5, 0.5), expected, rtol=0, atol=1e-15)
