"""Render a dataset: place a rig around a scene, render every split with Mitsuba."""

from __future__ import annotations

import dataclasses

import numpy as np
from tqdm.auto import tqdm

from .. import __version__
from ..errors import ConfigError, DataError
from ..scenes.gt_render import RenderSettings, exact_depth, render_color
from ..scenes.looks import roughness_of
from ..scenes.registry import SceneInfo
from .cameras import Cameras
from .dataset import Dataset, Split, bounds_from_cameras
from .rig import RigConfig, make_rig


def render_cameras(mi_scene, cams: Cameras, settings: RenderSettings) -> Split:
    """Ground truth of every view of ``cams``: colour, coverage, exact depth and mask."""
    if len(cams) == 0:
        z = np.zeros((0, cams.height, cams.width), np.float32)
        return Split.from_linear(cams, np.zeros(z.shape + (3,), np.float32), z, z, z.astype(bool))
    rgb, alpha = render_color(mi_scene, cams.mitsuba_frames(), cams.fov, cams.height, cams.width, settings)
    depth, mask = exact_depth(mi_scene, *cams.rays())
    return Split.from_linear(cams, rgb, alpha, depth, mask)


def check_framing(scene: SceneInfo, rig: RigConfig) -> None:
    """Refuse an object the rig's cameras would stand inside of, or a 2D outline they could not see whole (one drawn
    in pixels instead of about [-1, 1], say), with the fix."""
    r = scene.polygon.radius() if scene.polygon is not None else scene.radius
    fov = rig.fov if rig.fov is not None else (53.13 if rig.dim == 2 else 40.0)
    seen = rig.radius * np.sin(np.radians(fov / 2))          # the largest circle about the centre a camera sees whole
    scale = f"scale it to about [-1, 1] (divide its points by {r:.3g}), or "
    if r >= 0.95 * rig.radius:
        raise DataError(f"{scene.name} reaches {r:.3g} units from the centre and the cameras stand at "
                        f"{rig.radius:g}: they would be inside it; {scale}pass --radius above {1.2 * r:.3g}")
    if scene.polygon is not None and r > 1.02 * seen:          # (a 3D scene may stand on a table wider than views)
        raise DataError(f"{scene.name} reaches {r:.3g} units from the centre, but cameras at {rig.radius:g} with a "
                        f"{fov:g} degree view see {seen:.3g} of it; {scale}pass --radius "
                        f"{r / np.sin(np.radians(fov / 2)):.3g}")


def make_dataset(scene: SceneInfo, rig: RigConfig | None = None, render: RenderSettings | None = None,
                 progress: bool = True) -> Dataset:
    """Render train/val/test views of ``scene``; deterministic for ``rig.seed`` and ``render.seed``."""
    dim = 2 if scene.kind == "2d" else 3
    rig = rig or RigConfig(dim=dim)
    rig = rig if rig.dim == dim else dataclasses.replace(rig, dim=dim)
    check_framing(scene, rig)
    render = render or RenderSettings()
    if scene.lighting == "env" and render.integrator == "all_lights":
        raise ConfigError(f"{scene.name} is lit by an environment, which the all_lights integrator cannot sum; "
                          "render it with integrator 'path' (--integrator path, the default with --env)")
    cams = make_rig(rig).splits()
    mi_scene = scene.load()
    chunk = max(1, render.max_samples_per_launch // (rig.resolution * (1 if dim == 2 else rig.resolution) * render.spp))
    splits, total = {}, sum(len(c) for c in cams.values())
    with tqdm(total=total, desc=f"render {scene.name}", unit="view", disable=not progress, leave=False) as bar:
        for name, c in cams.items():
            parts = []
            for start in range(0, len(c), chunk):
                sub = c.subset(slice(start, start + chunk))
                parts.append(render_cameras(mi_scene, sub, dataclasses.replace(render, seed=render.seed + start)))
                bar.update(len(sub))
            splits[name] = Split.concatenate(parts) if parts else render_cameras(mi_scene, c, render)
    near, far = bounds_from_cameras(list(cams.values()), scene.radius)
    meta = {"scene": scene.name, "kind": scene.kind, "near": near, "far": far,
            "background": [0.0 if dim == 2 else 1.0] * 3, "rig": dataclasses.asdict(rig),
            "render": dataclasses.asdict(render), "generator": f"mitnerf {__version__}"}
    if scene.polygon is not None:
        meta["polygon"] = np.r_[scene.polygon.points, scene.polygon.points[:1]].tolist()
    meta.update({k: str(v) for k, v in (("mesh", scene.mesh), ("texture", scene.texture)) if v is not None})
    if (scene.material, scene.lighting) != ("diffuse", "points"):    # default datasets keep their bytes
        meta.update(material=scene.material, lighting=scene.lighting)
    roughness = roughness_of(scene.material, scene.roughness)         # None: a material without one
    if roughness is not None:
        meta["roughness"] = roughness
    return Dataset(splits, near, far, meta)
