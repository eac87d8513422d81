"""The linearly decoded hash grid: entries by hand, the sum of levels, levels joining, the torch twin."""

import numpy as np
import pytest
import torch
import drjit as dr
from drjit.auto.ad import Float, UInt32

from mitnerf.errors import CheckpointError, ConfigError
from mitnerf.fields.hashlinear import HashLinearConfig, HashLinearField, levels_of, vertex_entry
from mitnerf.reference.fields.hashlinear import HashLinearField as TwinField


def _field(**kw):
    return HashLinearField(HashLinearConfig(**kw))


def test_a_hashed_vertex_finds_its_entry_by_hand():
    # 5 x 5 = 25 vertices do not fit 2^4 = 16 entries: hashed. Vertex (1, 1): 1 ^ (1 * 2654435761)
    # = 0x9E3779B1 ^ 1 = 0x9E3779B0, and 0x9E3779B0 % 16 = 0. Vertex (2, 0): 2 % 16 = 2.
    lv = levels_of(HashLinearConfig(resolutions=(5,), dense_levels=0, log2_hashmap_size=4, initial_levels=1))
    assert lv.dense == (False,) and lv.sizes == (16,)
    assert int(vertex_entry([UInt32(1), UInt32(1)], 0, lv)[0]) == 0
    assert int(vertex_entry([UInt32(2), UInt32(0)], 0, lv)[0]) == 2
    # a level that fits its table is dense whatever dense_levels says: vertex (1, 1) of 3 x 3 is entry 1 + 3 = 4
    lv = levels_of(HashLinearConfig(resolutions=(3,), dense_levels=0, log2_hashmap_size=4, initial_levels=1))
    assert lv.dense == (True,) and int(vertex_entry([UInt32(1), UInt32(1)], 0, lv)[0]) == 4


def test_levels_sum_then_activate_by_hand():
    # bound 1: level 0 has vertices at -1, 0, 1 (3 x 3), level 1 at -1, -0.5, ..., 1 (5 x 5).
    f = _field(resolutions=(3, 5), dense_levels=2, view_dependent=False, density_activation="relu",
               density_scale=1.0, initial_levels=2, bound=1.0, tv_weight=0.0, tv_color_weight=0.0)
    a = f.init_numpy()
    assert a["density"].size == 9 + 25 and a["color"].size == 3 * (9 + 25)
    a["density"][:] = 0.0
    a["density"][:9] = 1.0                          # level 0: 1 everywhere
    a["density"][9 + 2 * 5 + 3] = 4.0               # level 1: vertex (x=3, y=2), at (0.5, 0)
    p = f.from_numpy(a)
    # at (0.25, 0): level 0 gives 1; level 1 lies halfway from vertex (2, 2) (0) to (3, 2) (4): 2. Sum 3.
    # at (0.5, 0.25): level 1 halfway from (3, 2) (4) to (3, 3) (0): 2; sum 3. Outside the bound: 0.
    s = f.density(p, [Float(0.25, 0.5, 1.5), Float(0.0, 0.25, 0.0)])
    np.testing.assert_allclose(np.asarray(s), [3.0, 3.0, 0.0], atol=1e-6)


def test_a_joining_level_leaves_the_field_unchanged():
    f = _field(resolutions=(9, 17, 33), dense_levels=1, log2_hashmap_size=6, initial_levels=1, add_level_at=(5, 10))
    p = f.init_params(1)
    assert f.levels_in(p) == 1 and f.schedule(4, p) is None
    rng = np.random.default_rng(0)
    x = [Float(v) for v in rng.uniform(-1.5, 1.5, (2, 400)).astype(np.float32)]
    t = rng.uniform(0, 2 * np.pi, 400).astype(np.float32)
    d = [Float(np.cos(t)), Float(np.sin(t))]
    before = f.query(p, x, d)
    q = f.schedule(10, p)                  # both joins at once: 9^2 dense, 2 x 2^6 hashed
    assert f.levels_in(q) == 3 and dr.width(q["density"]) == 81 + 64 + 64
    after = f.query(q, x, d)
    np.testing.assert_allclose(np.asarray(after[0]), np.asarray(before[0]), atol=1e-6)
    for u, v in zip(after[1], before[1]):
        np.testing.assert_allclose(np.asarray(u), np.asarray(v), atol=1e-6)


def test_bad_settings_and_checkpoints_say_so():
    with pytest.raises(ConfigError, match="increase"):
        HashLinearConfig(resolutions=(129, 65))
    f = _field(resolutions=(9, 17), initial_levels=2)
    with pytest.raises(CheckpointError, match="another configuration"):
        f.from_numpy({"density": np.zeros(10, np.float32), "color": np.zeros(30, np.float32)})


def _random(f, seed):
    a = f.init_numpy(seed)
    rng = np.random.default_rng(seed)
    return {k: rng.normal(0, 0.5, v.shape).astype(np.float32) for k, v in a.items()}


@pytest.mark.parametrize("dim", [2, 3])
def test_twin_agrees_on_values_and_gradients(dim):
    """The same random tables and cotangents through both: outputs, table gradients and the total variation."""
    levels = dict(resolutions=(5, 9, 17), view_levels=2, sh_degree=2) if dim == 2 else dict(resolutions=(3, 9))
    cfg = HashLinearConfig(dim=dim, dense_levels=1, log2_hashmap_size=7, initial_levels=3, tv_samples=0,
                           tv_weight=1e-3, tv_color_weight=1e-2, **levels)
    f, t = HashLinearField(cfg), TwinField(cfg)
    arrays = _random(f, 2)
    t.load_numpy(arrays)
    rng = np.random.default_rng(3)
    n = 300
    x = rng.uniform(-1.6, 1.6, (n, dim)).astype(np.float32)
    d = rng.normal(size=(n, dim)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    cot = rng.normal(size=(n, 4)).astype(np.float32)
    p = f.from_numpy(arrays)
    for v in p.values():
        dr.enable_grad(v)
    s, c = f.query(p, [Float(v) for v in x.T], [Float(v) for v in d.T])
    reg = f.regularizer(p, UInt32(7))
    dr.backward(dr.sum(s * cot[:, 0]) + sum(dr.sum(ci * cot[:, k + 1]) for k, ci in enumerate(c)) + reg)
    ts, tc = t.query(torch.from_numpy(x), torch.from_numpy(d))
    treg = t.regularizer(7)
    ((ts * torch.from_numpy(cot[:, 0])).sum() + (tc * torch.from_numpy(cot[:, 1:])).sum() + treg).backward()
    np.testing.assert_allclose(np.asarray(s), ts.detach().numpy(), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(np.stack([np.asarray(ci) for ci in c], 1), tc.detach().numpy(), atol=1e-5)
    np.testing.assert_allclose(float(reg[0]), float(treg.detach()), rtol=1e-4)
    for k, tp in (("density", t.density_table), ("color", t.color_table)):
        np.testing.assert_allclose(np.asarray(dr.grad(p[k])), tp.grad.numpy(), rtol=1e-3, atol=1e-4)


def test_auto_judges_its_size_with_every_level():
    from mitnerf.train.auto import LADDER, final_params

    args = dict(LADDER[2])["hashlinear"]
    # 65^2 x (1 + 3 x 3) + 129^2 x (1 + 3) + 2^13 x (1 + 3): the harmonics on the coarsest level only
    assert final_params("hashlinear", args, 2) == 65 ** 2 * 10 + 129 ** 2 * 4 + 2 ** 13 * 4 == 141_582
