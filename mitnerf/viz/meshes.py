"""The learned mesh beside the ground-truth mesh, rendered off-screen by pyvista.

``plot_mesh_comparison(learned, truth_ply, "mesh.png", texture_path=...)`` draws two
panels with linked cameras: the marching-cubes mesh of the field (grey, smooth shaded)
on the left, the scene's own mesh (with its vertex colours or texture, see
:func:`mitnerf.viz.rigs.object_mesh`) on the right. Both are seen from the same
viewpoint, ``azimuth``/``elevation`` degrees around the z axis at ``distance`` with a
``fov`` degree view, like the test orbit. ``note`` (e.g. the Chamfer distance) is written under the panels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..geometry.mesh import Mesh, as_mesh
from .rigs import add_object_mesh


def _camera(center, distance: float, azimuth: float, elevation: float):
    az, el = np.radians(azimuth), np.radians(elevation)
    c = np.asarray(center, float)
    pos = c + distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return [tuple(pos), tuple(c), (0.0, 0.0, 1.0)]


def plot_mesh_comparison(learned: Mesh | str | Path, truth_path: str | Path | None, path: str | Path,
                         texture_path: str | Path | None = None, note: str = "", azimuth: float = 30.0,
                         elevation: float = 25.0, distance: float = 3.5, fov: float = 40.0,
                         center=(0.0, 0.0, 0.0), window=(1200, 600)) -> Path:
    """Two linked panels, learned | ground truth; writes a PNG at ``path`` and returns it."""
    import pyvista as pv
    import vtk


    vtk.vtkObject.GlobalWarningDisplayOff()     # no display here: VTK warns about X on every plot
    learned = as_mesh(learned)
    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=list(window), border=False)
    pl.set_background("white")
    pl.subplot(0, 0)
    title = "learned" + (f" (density level {learned.level:.3g})" if learned.level is not None else "")
    pl.add_text(f"{title}\n{len(learned.vertices)} vertices, {len(learned.faces)} faces", font_size=10,
                color="black")
    if len(learned.faces):
        pl.add_mesh(learned.to_pyvista(), color="lightsteelblue", smooth_shading=True)
    else:
        pl.add_text("no surface", position="upper_right", color="red")
    pl.camera_position = _camera(center, distance, azimuth, elevation)
    pl.camera.view_angle = fov
    pl.subplot(0, 1)
    if truth_path is not None and Path(truth_path).exists():
        add_object_mesh(pl, truth_path, texture_path)
        pl.add_text(f"ground truth\n{Path(truth_path).name}", font_size=10, color="black")
    else:
        pl.add_text("no ground-truth mesh", font_size=10, color="red")
    pl.camera_position = _camera(center, distance, azimuth, elevation)
    pl.camera.view_angle = fov
    pl.link_views()
    if note:
        pl.subplot(0, 0)
        pl.add_text(note.replace(" (", "\n("), position="lower_left", font_size=9, color="black")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pl.screenshot(str(path))
    pl.close()
    return path
