"""Anderson mixing: the cached-Gram update against an independent least-squares solve."""

import numpy as np
from numpy.testing import assert_allclose

from sacflow.solver.anderson import AndersonMixer


def reference_step(xs, fs, mixing=1.0):
    """Walker & Ni type II step from the full history, solved with a QR-based lstsq."""
    x, f = xs[-1], fs[-1]
    dX = np.stack([b - a for a, b in zip(xs[:-1], xs[1:], strict=True)], axis=1)
    dF = np.stack([b - a for a, b in zip(fs[:-1], fs[1:], strict=True)], axis=1)
    gamma, *_ = np.linalg.lstsq(dF, f, rcond=None)
    return x + mixing * f - (dX + mixing * dF) @ gamma


def test_step_matches_least_squares_with_a_full_and_a_rolling_history():
    rng = np.random.default_rng(3)
    depth, n = 3, 50
    mixer = AndersonMixer(depth, mixing=0.7)
    xs, fs = [], []
    for k in range(7):  # more steps than the depth: the oldest columns roll out
        x = rng.standard_normal(n)
        gx = rng.standard_normal(n)
        out = mixer.step(x, gx)
        xs.append(x)
        fs.append(gx - x)
        if k == 0:
            assert_allclose(out, x + 0.7 * (gx - x))
        else:
            keep = min(k, depth) + 1
            assert_allclose(out, reference_step(xs[-keep:], fs[-keep:], 0.7), rtol=1e-9,
                            atol=1e-9)


def test_linear_fixed_point_converges_like_gmres():
    """On x = M x + b in n dimensions, depth ≥ n reaches the fixed point in about n steps."""
    rng = np.random.default_rng(4)
    n = 6
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    M = q @ np.diag(np.linspace(0.2, 0.95, n)) @ q.T
    b = rng.standard_normal(n)
    exact = np.linalg.solve(np.eye(n) - M, b)
    mixer = AndersonMixer(depth=n)
    x = np.zeros(n)
    for _ in range(n + 2):
        x = mixer.step(x, M @ x + b)
    assert np.abs(x - exact).max() < 1e-8 * np.abs(exact).max()
    # plain Picard iteration is far from converged after the same number of sweeps
    y = np.zeros(n)
    for _ in range(n + 2):
        y = M @ y + b
    assert np.abs(y - exact).max() > 1e-2 * np.abs(exact).max()


def test_sparse_vectors_with_a_growing_support_mix_as_dense_ones():
    """Vectors zero outside a support that grows step by step (a spreading plastic zone): the
    history kept on the support gives the dense least-squares iterates, zero outside it."""
    rng = np.random.default_rng(5)
    depth, n = 3, 400
    mixer = AndersonMixer(depth, mixing=0.8)
    xs, fs = [], []
    for k in range(8):
        x, gx = np.zeros(n), np.zeros(n)
        live = rng.choice(20 + 30 * k, size=15, replace=False)  # within a growing prefix
        x[live] = rng.standard_normal(live.size)
        gx[live[:10]] = rng.standard_normal(10)
        out = mixer.step(x, gx)
        xs.append(x)
        fs.append(gx - x)
        keep = min(k, depth) + 1
        expected = x + 0.8 * (gx - x) if k == 0 else reference_step(xs[-keep:], fs[-keep:], 0.8)
        assert_allclose(out, expected, rtol=1e-9, atol=1e-9)
        assert not out[20 + 30 * k:].any()  # nothing where no vector ever was nonzero
    assert mixer._support.size < n


def test_a_support_growing_before_and_between_its_entries_mixes_as_dense_vectors():
    """New nonzeros land before, between and after the kept ones (a plastic zone spreading in
    every direction of the flattened box): the widened history stays aligned with its entries,
    and after a reset the support starts again from the new vectors."""
    rng = np.random.default_rng(11)
    depth, n = 4, 300
    mixer = AndersonMixer(depth, mixing=0.9)
    for _ in range(2):  # the second round after a reset
        xs, fs, ever = [], [], np.zeros(n, dtype=bool)
        for k in range(9):
            x, gx = np.zeros(n), np.zeros(n)
            live = rng.choice(np.arange(n - 30 * (k + 1), n, 3), size=8, replace=False)
            x[live] = rng.standard_normal(live.size)
            gx[rng.choice(n, size=4, replace=False)] = rng.standard_normal(4)
            ever |= (x != 0) | (gx != 0)
            out = mixer.step(x, gx)
            xs.append(x)
            fs.append(gx - x)
            keep = min(k, depth) + 1
            expected = (x + 0.9 * (gx - x) if k == 0
                        else reference_step(xs[-keep:], fs[-keep:], 0.9))
            assert_allclose(out, expected, rtol=1e-9, atol=1e-9)
            assert not out[~ever].any()
        mixer.reset()


def test_a_deepened_history_mixes_as_one_that_was_deep_from_the_start():
    """``deepen`` keeps the stored differences: the steps are those of the deeper mixer.

    Deepened while it holds fewer differences than its old depth, a depth-2 mixer then takes
    bit for bit the steps of a depth-4 one fed the same iterates (and more than 2 differences,
    which the old depth would have rolled out).
    """
    rng = np.random.default_rng(5)
    n = 30
    shallow, deep, kept = AndersonMixer(2), AndersonMixer(4), AndersonMixer(2)
    for k in range(8):
        if k == 2:  # one difference stored
            shallow.deepen(4)
        x, gx = rng.standard_normal(n), rng.standard_normal(n)
        step = shallow.step(x, gx)
        assert np.array_equal(step, deep.step(x, gx))
        rolled = kept.step(x, gx)  # the depth-2 mixer: from the 4th step on, another one
        assert np.array_equal(step, rolled) == (k < 3)
    assert shallow.depth == 4


def test_a_shaped_support_grows_by_a_margin_and_mixes_as_dense_vectors():
    """Given the vectors' shape, a growing support is widened by SUPPORT_MARGIN cells along the
    axes but the last: a zone spreading by one cell a step is laid out again less often, the
    iterates are still the dense least-squares ones and zero where no vector was ever nonzero."""
    rng = np.random.default_rng(12)
    shape, depth = (12, 12, 6, 3), 4
    shaped, flat = AndersonMixer(depth, 0.8, shape=shape), AndersonMixer(depth, 0.8)
    layouts = {"shaped": 0, "flat": 0}
    xs, fs, ever = [], [], np.zeros(shape, dtype=bool)
    for k in range(8):  # a box of nonzeros growing by one cell along each axis
        x, gx = np.zeros(shape), np.zeros(shape)
        x[: 3 + k, : 3 + k, : 1 + k // 2] = rng.standard_normal((3 + k, 3 + k, 1 + k // 2, 3))
        gx[: 4 + k, : 3 + k, : 1 + k // 2] = rng.standard_normal((4 + k, 3 + k, 1 + k // 2, 3))
        ever |= (x != 0) | (gx != 0)
        xs.append(x.ravel())
        fs.append((gx - x).ravel())
        keep = min(k, depth) + 1
        expected = xs[0] + 0.8 * fs[0] if k == 0 else reference_step(xs[-keep:], fs[-keep:], 0.8)
        for name, mixer in (("shaped", shaped), ("flat", flat)):
            before = mixer._support.size
            out = mixer.step(x.ravel(), gx.ravel())
            layouts[name] += mixer._support.size != before
            assert_allclose(out, expected, rtol=1e-9, atol=1e-9)
            assert not out[~ever.ravel()].any()
    kept = np.isin(np.arange(x.size), shaped._support).reshape(shape)
    grown = np.zeros(shape, dtype=bool)
    grown[:12, :11, :5] = True  # every nonzero so far (:11, :10, :4) grown by one cell
    assert kept[ever].all() and not kept[~grown].any()
    assert layouts["shaped"] < layouts["flat"] == 8



def test_fused_column_dots_are_the_dot_products_whatever_the_threads(monkeypatch):
    """The Gram row and the right-hand side come from one pass over the vectors, in partial
    sums over fixed blocks: the products of numpy to rounding, and the same bits on one thread
    or shared out between two or three (as the iterates must be)."""
    from sacflow.machine import threads as thread_budget
    from sacflow.solver import vector_passes
    from sacflow.solver.vector_passes import DOT_BLOCK, column_dots

    rng = np.random.default_rng(11)
    size = 5 * DOT_BLOCK + 123  # a last block shorter than the others
    columns = [rng.standard_normal(size) for _ in range(4)]
    a, b = rng.standard_normal(size), rng.standard_normal(size)
    monkeypatch.setattr(thread_budget, "SPLIT_ITEMS", 1)  # share even this small pass out
    results = {}
    for count in (1, 2, 3):
        monkeypatch.setattr(vector_passes, "threads", lambda count=count: count)
        results[count] = column_dots(columns, a, b)
    with_a, with_b = results[1]
    assert_allclose(with_a, [c @ a for c in columns], rtol=1e-12)
    assert_allclose(with_b, [c @ b for c in columns], rtol=1e-12)
    for count in (2, 3):
        np.testing.assert_array_equal(results[count][0], with_a)
        np.testing.assert_array_equal(results[count][1], with_b)
    empty_a, empty_b = column_dots([], a, b)
    assert empty_a.shape == empty_b.shape == (0,)
    monkeypatch.undo()  # vectors that stay in the cache: numpy's own products, to the bit
    in_cache_a, in_cache_b = column_dots(columns, a, b)
    assert list(in_cache_a) == [float(c @ a) for c in columns]
    assert list(in_cache_b) == [float(c @ b) for c in columns]
