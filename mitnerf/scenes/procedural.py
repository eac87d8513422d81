"""Procedural 2D scenes (MNIST1D-style: the seed is the argument) for training fields across many scenes
(pixelNeRF). :func:`random_outline`: a star-shaped outline (radial harmonics plus per-vertex noise, 6 to 40
vertices, increasing angles, positive radii) with a random turn, so the colour cycle starts anywhere.
:func:`outline_scene`: its scene, the four point lights at a random radius in [3.0, 3.5] and intensity in
[9, 12] (the range of the named 2D scenes), so the lighting gives nothing away."""

from __future__ import annotations

import dataclasses

import numpy as np

from .polygon import Polygon
from .registry import SceneInfo, scene_2d


def random_outline(seed: int, max_radius: tuple = (1.0, 1.6)) -> Polygon:
    """A star-shaped random outline whose largest radius is drawn from ``max_radius``."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 41))
    angle = rng.uniform(0, 2 * np.pi) + 2 * np.pi * (np.arange(n) + rng.uniform(-0.35, 0.35, n)) / n  # gaps < pi
    m = np.arange(1, 5)
    amp = rng.uniform(0, 1, 4) * 0.35 / m
    phase = rng.uniform(0, 2 * np.pi, 4)
    noise = rng.choice([0.02, 0.08, 0.2])
    r = 1 + (amp[:, None] * np.cos(m[:, None] * angle[None] + phase[:, None])).sum(0) + noise * rng.standard_normal(n)
    r = np.maximum(r, 0.3)
    r = r / r.max() * rng.uniform(*max_radius)
    pts = np.stack([r * np.cos(angle), r * np.sin(angle)], 1)
    return Polygon.from_points(np.r_[pts, pts[:1]], f"outline{seed}")


def outline_scene(seed: int) -> SceneInfo:
    """The scene of :func:`random_outline` ``(seed)``, with randomised lights."""
    rng = np.random.default_rng([seed, 1])
    info = scene_2d(random_outline(seed))
    lights = {"light_radius": f"{rng.uniform(3.0, 3.5):.4f}", "light_intensity": f"{rng.uniform(9.0, 12.0):.4f}"}
    return dataclasses.replace(info, variables={**info.variables, **lights})
