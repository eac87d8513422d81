"""Fields: encodings, both evaluation modes, weight transfer to and from torch."""

import numpy as np
import pytest
import torch
from drjit.auto.ad import Float

from mitnerf.fields.encoding import angle_harmonics, encoded_size, positional_encoding
from mitnerf.fields.harmonics import view_basis
from mitnerf.fields.mlp import NeRFConfig, NeRFField, init_weights
from mitnerf.reference.fields.mlp import NeRFField as TorchField


def test_angle_harmonics_by_hand():
    # t = 30 degrees: (cos t, sin t, cos 2t, sin 2t, cos 4t, sin 4t)
    t = np.radians(30.0)
    out = angle_harmonics([Float(np.cos(t)), Float(np.sin(t))], 3)
    np.testing.assert_allclose([float(v[0]) for v in out],
                               [np.cos(t), np.sin(t), np.cos(2 * t), np.sin(2 * t), np.cos(4 * t), np.sin(4 * t)],
                               atol=1e-6)


def test_view_harmonics_by_hand_in_both_backends():
    # t = 30 degrees, degree 3: (1, cos t, sin t, cos 2t, sin 2t, cos 3t, sin 3t) = (1, .866, .5, .5, .866, 0, 1)
    t = np.radians(30.0)
    want = [1, np.cos(t), np.sin(t), 0.5, np.sqrt(0.75), 0, 1]
    got = view_basis([Float(np.cos(t)), Float(np.sin(t))], 3)
    np.testing.assert_allclose([float(v[0]) for v in got], want, atol=1e-6)
    got = view_basis([torch.tensor([np.cos(t)]), torch.tensor([np.sin(t)])], 3)
    np.testing.assert_allclose([float(v[0]) for v in got], want, atol=1e-6)
    assert len(view_basis([Float(0.6), Float(0.0), Float(0.8)], 2)) == 9    # 3D: a sphere's 1 + 3 + 5


def test_positional_encoding_size_and_values():
    x = [Float(0.25), Float(-0.5)]
    enc = positional_encoding(x, 2)
    assert len(enc) == encoded_size(2, 2) == 10
    # [x, y, sin(pi x), sin(pi y), cos(pi x), cos(pi y), sin(2 pi x), ...]
    np.testing.assert_allclose(float(enc[2][0]), np.sin(np.pi * 0.25), atol=1e-6)
    np.testing.assert_allclose(float(enc[9][0]), np.cos(2 * np.pi * -0.5), atol=1e-6)


def test_the_frequency_window_by_hand_in_both_backends():
    # x = 0.25, L = 3, opened = 1.4: band 0 whole, band 1 at 0.4, band 2 shut:
    # [x, sin(pi x), cos(pi x), 0.4 sin(2 pi x), 0.4 cos(2 pi x), 0, 0] = [.25, .7071, .7071, .4, 0, 0, 0]
    from mitnerf.reference.fields.encoding import positional_encoding as positional_encoding_torch
    want = [0.25, np.sqrt(0.5), np.sqrt(0.5), 0.4, 0.0, 0.0, 0.0]
    got = positional_encoding([Float(0.25)], 3, Float(1.4))
    np.testing.assert_allclose([float(v[0]) for v in got], want, atol=1e-6)
    np.testing.assert_allclose(positional_encoding_torch(torch.tensor([[0.25]]), 3, 1.4)[0].numpy(), want, atol=1e-6)


def test_the_field_opens_its_window_with_the_step_as_its_twin_does():
    # pe_window = 100 steps for L = 4: at step 30, 1.2 bands are open; with no step, all are
    cfg = NeRFConfig(dim=3, width=16, depth=4, pos_L=4, dir_L=2, pe_window=100)
    w = init_weights(cfg, 2)
    x = np.random.default_rng(3).uniform(-1, 1, (64, 3)).astype(np.float32)
    f, tf = NeRFField(cfg), TorchField(cfg)
    p = f.from_numpy(w)
    tf.load_numpy(w)
    xs = [Float(v) for v in x.T]
    full, at30 = (np.asarray(f.density({**p, **step}, xs)) for step in ({}, {"step": Float(30.0)}))
    tf.step = 30                                     # what the torch engine sets at step 30
    with torch.no_grad():
        np.testing.assert_allclose(at30, tf.density(torch.from_numpy(x)).numpy(), atol=2e-6)
    assert np.abs(at30 - full).max() > 1e-3          # the shut bands change the field
    enc = positional_encoding(xs, 4, Float(30.0 * 4 / 100))
    assert not np.asarray(enc[3 + 6 * 2]).any() and np.asarray(enc[3 + 6]).any()


@pytest.mark.parametrize("dim", [2, 3])
def test_modes_and_twin_agree_and_weights_round_trip(dim):
    cfg = NeRFConfig(dim=dim, width=16, depth=4, pos_L=5, dir_L=3)
    w = init_weights(cfg, 1)
    rng = np.random.default_rng(0)
    x = rng.uniform(-1.5, 1.5, (500, dim)).astype(np.float32)
    d = rng.normal(size=(500, dim)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    outs = []
    for mode in ("coopvec", "tensor"):
        f = NeRFField(NeRFConfig(**{**cfg.__dict__, "mode": mode}))
        p = f.from_numpy(w)
        back = f.to_numpy(p)
        assert all(np.array_equal(back[k], w[k]) for k in w)
        s, c = f.query(p, [Float(v) for v in x.T], [Float(v) for v in d.T])
        outs.append((np.asarray(s), np.stack([np.asarray(v) for v in c], 1)))
    tf = TorchField(cfg)
    tf.load_numpy(w)
    assert all(np.array_equal(tf.to_numpy()[k], w[k]) for k in w)
    with torch.no_grad():
        ts, tc = tf.query(torch.from_numpy(x), torch.from_numpy(d))
    for s, c in outs:
        np.testing.assert_allclose(s, ts.numpy(), atol=2e-6)
        np.testing.assert_allclose(c, tc.numpy(), atol=1e-6)


def test_bad_checkpoint_shapes_say_so():
    f = NeRFField(NeRFConfig(width=16))
    w = init_weights(NeRFConfig(width=32), 0)
    with pytest.raises(ValueError, match="another architecture"):
        f.from_numpy(w)


@pytest.mark.parametrize("field, args", [("vanilla", dict(width=16, depth=3)), ("grid", dict(resolution=9)),
                                         ("hashgrid", dict(n_levels=4, log2_hashmap_size=8, hidden=8,
                                                           geo_features=3)),
                                         ("hashlinear", dict(resolutions=(5, 9, 17), log2_hashmap_size=6))])
def test_weight_transfer_round_trip(field, args):
    from mitnerf.render.pipeline import RenderConfig
    from mitnerf.train.backend_drjit import build_model
    from mitnerf.train.backend_torch import build_torch_model
    from mitnerf.train.config import ModelConfig

    mc = ModelConfig(field, args, RenderConfig(n_coarse=8, n_fine=4))
    model, twin = build_model(mc, 2, 1.5), build_torch_model(mc, 2, 1.5)
    params = model.init_params(3)
    twin.load_numpy(model.to_numpy(params))                  # through the canonical numpy form, both ways
    back = model.to_numpy(model.from_numpy(twin.to_numpy()))
    ref = model.to_numpy(params)
    assert back.keys() == ref.keys()
    for k in ref:
        np.testing.assert_array_equal(back[k], ref[k])


# (traceable, skips_color, freezable) of each family as built; Field's defaults are (False, False, True)
CAPABILITIES = [("grid", {}, (True, True, True)), ("hashlinear", {}, (True, True, True)),
                ("vanilla", dict(mode="tensor"), (False, False, True)),
                ("vanilla", dict(mode="coopvec"), (True, False, True)),
                ("vanilla", dict(mode="native"), (False, False, False)),      # a C call cannot be recorded
                ("hashgrid", {}, (False, False, True)), ("hashgrid", dict(mode="coopvec"), (True, False, True)),
                ("pixelnerf", {}, (False, False, True))]


@pytest.mark.parametrize("family, args, want", CAPABILITIES)
def test_every_family_honours_the_field_contract(family, args, want):
    from mitnerf.fields import FIELDS, make_field
    from mitnerf.fields.base import Field, FieldConfig
    from mitnerf.reference.fields import TORCH_FIELDS
    from mitnerf.reference.fields.mlp import TwinField

    config, cls = FIELDS[family]
    assert issubclass(cls, Field) and issubclass(config, FieldConfig) and not cls.__abstractmethods__
    f = make_field(family, **args, bound=1.25)
    got = (f.traceable, f.skips_color, f.freezable)
    assert all(type(v) is bool for v in got) and got == want
    assert f.bound == 1.25 and f.dim == 2                    # what a renderer reads, not f.cfg
    assert type(f.cfg.final()) is config and type(f.cfg.schedule_end) is int
    assert family not in TORCH_FIELDS or issubclass(TORCH_FIELDS[family], TwinField)


def test_every_family_is_listed_in_the_contract_test():
    from mitnerf.fields import FIELDS

    assert {family for family, _, _ in CAPABILITIES} == set(FIELDS)


def test_the_native_mode_without_a_compiler_says_how_to_fix_it(monkeypatch):
    import mitnerf.fields.mlp as mlp
    from mitnerf.errors import EnvironmentProblem

    monkeypatch.setattr(mlp, "library", lambda: None)
    f = NeRFField(NeRFConfig(mode="native"))
    assert set(f.init_numpy(0)) >= {"trunk.0.weight", "sigma.bias"}      # the torch engine starts from these
    with pytest.raises(EnvironmentProblem, match="--set mode=tensor"):
        f.init_params(0)                                                 # Dr.Jit storage for the kernel
    with pytest.raises(ValueError, match="mode must be one of native, coopvec, tensor"):
        NeRFConfig(mode="auto")                                  # no mode chosen by machine


def _native_gradients(cfg, w, x, d, cot):
    """Weight, position and direction gradients of the native MLP under the cotangents ``cot`` ``[M, 4]``, and the
    spare stashes its field holds after the backward."""
    import drjit as dr
    f = NeRFField(cfg)
    p = f.from_numpy(w)
    dr.enable_grad(p["mlp"])
    xs, ds = [Float(v) for v in x.T], [Float(v) for v in d.T]
    dr.enable_grad(xs, ds)
    s, c = f.query(p, xs, ds)
    dr.backward(dr.sum(s * Float(cot[:, 0])) + sum(dr.sum(ck * Float(cot[:, k + 1])) for k, ck in enumerate(c)))
    grads = (np.asarray(dr.grad(p["mlp"])), *(np.stack([np.asarray(dr.grad(v)) for v in u], 1) for u in (xs, ds)))
    return grads, len(f.stashes.free)


def test_the_native_backward_from_the_stash_is_the_recomputed_one(monkeypatch):
    """The forward's kept activations give the backward what recomputing them gives: each sample's input gradient
    bit for bit, the weight gradients up to the order of the tiles' sums (the stash keeps the forward's tiles), over a
    sample count that leaves the last tile part empty."""
    from mitnerf.fields import native
    if native.library() is None:
        pytest.skip("no C compiler here: the native MLP cannot be built")
    cfg = NeRFConfig(dim=3, width=32, depth=4, pos_L=4, dir_L=2, mode="native")
    w = init_weights(cfg, 2)
    rng = np.random.default_rng(3)
    x = rng.uniform(-1.5, 1.5, (1000, 3)).astype(np.float32)
    d = rng.normal(size=(1000, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    cot = rng.normal(size=(1000, 4)).astype(np.float32)
    kept, spares = _native_gradients(cfg, w, x, d, cot)
    monkeypatch.setattr(native, "STASH_BYTES", 0)                  # too small for any stash: recompute
    again, none = _native_gradients(cfg, w, x, d, cot)
    assert (spares, none) == (1, 0)                                # the stash was used, then given back
    assert all(np.abs(g).max() > 0 for g in kept)
    for a, b in zip(kept[1:], again[1:]):
        np.testing.assert_array_equal(a, b)                        # per sample: the same sums, bit for bit
    np.testing.assert_allclose(kept[0], again[0], rtol=1e-4, atol=1e-6 * np.abs(again[0]).max())   # tile order


def test_stashes_hand_out_the_smallest_spare_that_fits():
    from mitnerf.fields.native import Stashes
    s = Stashes(spare=2)
    a = s.take(100)                   # none spare: a new one, an eighth larger: 112 floats
    assert a.buffer.size == 112 and a.buffer.ctypes.data % 64 == 0
    b = s.take(200)                   # 225
    a.end()
    a.end()                           # once only
    del b                             # a lease dropped unended gives its buffer back too
    assert [len(f) for f in s.free] == [225, 112]
    assert s.take(90).buffer.size == 112           # both fit: the smaller (the lease, dropped, gives it back)
    kept = s.take(90)
    c = s.take(300)                   # 225 and 112 are out or too small: a new one, 337
    kept.end()
    c.end()                           # three spares: the largest two stay
    assert [len(f) for f in s.free] == [337, 225]
