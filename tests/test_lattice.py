"""Lattice records (:mod:`mitnerf.fields.lattice`): padded to whole packets, read a packet at a time, and the dense
grid that stores its colour so (``GridConfig.color_packets``)."""

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Bool, Float, UInt32

from mitnerf.fields.grid import GridConfig, GridField
from mitnerf.fields.lattice import read_record, record_layout


def test_records_are_padded_to_whole_packets_where_that_adds_at_most_a_quarter():
    # 27 -> 32 floats read 16 at a time (adds 5, at most 27 / 4 = 6.75); 15 -> 16; 12 is three packets of 4; 11 ->
    # 12 (16 would add 5 > 2.75); 3 and 1 stay, read one by one (a packet of 4 would add 1 > 0.75, 3 > 0.25); 48 is
    # three packets of 16
    assert [record_layout(c) for c in (27, 15, 12, 11, 3, 1, 48)] == \
        [(32, 16), (16, 16), (12, 4), (12, 4), (3, 1), (1, 1), (48, 16)]


@pytest.mark.parametrize("channels, layout", [(27, (32, 16)), (15, (16, 16)), (11, (12, 4)), (3, (3, 1)),
                                              (48, (48, 16)), (12, (12, 1)), (12, (16, 16))])
def test_a_record_read_in_packets_holds_its_floats_in_order(channels, layout):
    # vertex v's float c is 100 v + c, its pad floats -1; vertices 2, 0 (lane inactive: zeros) and 4 read
    grid = np.full((5, layout[0]), -1.0, np.float32)
    grid[:, :channels] = 100 * np.arange(5)[:, None] + np.arange(channels)
    got = read_record(Float(grid.ravel()), channels, UInt32([2, 0, 4]), Bool([True, False, True]), layout)
    assert len(got) == channels
    want = [200 + np.arange(channels), np.zeros(channels), 400 + np.arange(channels)]
    np.testing.assert_array_equal(np.array([np.asarray(v) for v in got]).T, want)


@pytest.mark.parametrize("args, floats, stride", [
    (dict(dim=3, resolution=5, view_dependent=True, density_refine=2), 12, 12),     # RGB harmonics of degree 1
    (dict(dim=3, resolution=5, view_dependent=True, sh_degree=2), 27, 32),          # of degree 2
    (dict(dim=2, resolution=9, view_dependent=True, sh_degree=2), 15, 16),          # a circle's, degree 2
])
def test_a_grid_in_packets_is_the_same_field_with_the_same_gradients(args, floats, stride):
    """Queries, the total variation and their gradients equal those of the grid stored float by float; the pad floats
    get no gradient; weights leave and come back without them."""
    cfgs = [GridConfig(**args, tv_weight=0.1, tv_color_weight=0.3, color_packets=p) for p in (True, False)]
    assert [(c.color_floats, c.color_stride) for c in cfgs] == [(floats, stride), (floats, floats)]
    rng = np.random.default_rng(7)
    fields = [GridField(c) for c in cfgs]
    arrays = {k: rng.normal(size=v.shape).astype(np.float32) for k, v in fields[0].init_numpy(0).items()}
    n, D = 300, args["dim"]
    x = [Float(v) for v in rng.uniform(-1.2, 1.2, (D, n)).astype(np.float32)]
    d = rng.normal(size=(D, n)).astype(np.float32)
    d = [Float(v) for v in d / np.linalg.norm(d, axis=0)]
    w = [Float(v) for v in rng.normal(size=(4, n)).astype(np.float32)]
    outs, grads = [], []
    for f in fields:
        params = f.from_numpy(arrays)
        for v in params.values():
            dr.enable_grad(v)
        sigma, rgb = f.query(params, x, d)
        loss = dr.sum(w[0] * sigma + sum(wi * c for wi, c in zip(w[1:], rgb))) + f.regularizer(params, UInt32(5))
        dr.backward(loss)
        outs.append(np.array([np.asarray(v) for v in (sigma, *rgb)]))
        grads.append(f.to_numpy({k: dr.grad(v) for k, v in params.items()}))
        np.testing.assert_array_equal(f.to_numpy(params)["color"], arrays["color"])
        assert dr.width(params["color"]) == arrays["color"].size // floats * f.cfg.color_stride
    assert np.abs(np.asarray(dr.grad(params["color"]))).max() > 0
    np.testing.assert_allclose(outs[0], outs[1], rtol=1e-6, atol=1e-6)
    for k in grads[0]:
        np.testing.assert_allclose(grads[0][k], grads[1][k], rtol=1e-4, atol=1e-6)
    packed = fields[0].from_numpy(arrays)["color"]
    dr.enable_grad(packed)
    dr.backward(dr.sum(fields[0].query({**fields[0].from_numpy(arrays), "color": packed}, x, d)[1][0]))
    pads = np.asarray(dr.grad(packed)).reshape(-1, stride)[:, floats:]
    assert not pads.any()


def test_adams_moments_leave_and_come_back_without_the_pad_floats(bunny_small):
    """A checkpoint's moments hold the weights' floats without the pad floats, and load back into the padded
    optimizer as they were, flat (as checkpoints written before the padding hold them) or not."""
    from conftest import small

    from mitnerf.train.fit import fit

    run = fit(bunny_small, small("grid-2d", iters=3), "drjit")
    be = run.backend
    assert be.model.fields["coarse"].cfg.color_layout == (16, 16)           # 15 floats: harmonics of degree 2
    weights, state = be.model_weights(), be.optimizer_state()
    for k, w in weights.items():
        assert state[f"{k}.m"].size == state[f"{k}.v"].size == w.size
    assert state["coarse.color.m"].shape[-1] == 15 and np.abs(state["coarse.color.v"]).max() > 0
    saved = {k: np.array(v) for k, v in state.items()}
    for flat in (False, True):
        be.load_optimizer_state({k: (v.ravel() if flat else v) * (2 if k.endswith(".m") else 1)
                                 for k, v in saved.items()})
        again = be.optimizer_state()
        for k, v in saved.items():
            np.testing.assert_array_equal(again[k], v * 2 if k.endswith(".m") else v)
