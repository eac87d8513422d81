"""Datasets rendered once and reused under ``$MITNERF_CACHE``, named by a hash of the scene, its look as resolved
today (material, lighting, the roughness a default gives), rig and render settings, filled atomically
(:func:`mitnerf._io.cache_entry`): concurrent requests render privately and the first to finish provides it to
all."""

from __future__ import annotations

import dataclasses
import json

from .._io import cache_entry, digest
from ..scenes.gt_render import RenderSettings
from ..scenes.looks import roughness_of
from ..scenes.registry import get_scene
from .dataset import Dataset
from .formats import WRITERS, load_dataset
from .generate import make_dataset
from .rig import RigConfig


def cached_dataset(scene: str, rig: RigConfig, render: RenderSettings | None = None) -> Dataset:
    """The dataset of ``scene`` seen by ``rig``, rendered on first use."""
    render = render or RenderSettings()
    info = get_scene(scene)
    look = {"material": info.material, "lighting": info.lighting, "roughness": roughness_of(info.material,
                                                                                           info.roughness)}
    key = digest(scene, json.dumps(dataclasses.asdict(rig), sort_keys=True),
                 json.dumps(dataclasses.asdict(render), sort_keys=True), json.dumps(look, sort_keys=True))

    def build(tmp):
        ds = make_dataset(info, rig, render, progress=False)
        WRITERS["nerf2d" if ds.dim == 2 else "blender"](ds, tmp)

    return load_dataset(cache_entry(f"datasets/{scene}-{key}", build))
