"""Camera rigs as pictures (matplotlib in 2D, off-screen pyvista in 3D) and the learned mesh beside the truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data.cameras import Cameras
from ..data.color import linear_to_srgb
from ..geometry.mesh import Mesh, as_mesh
from ..scenes.ply import read_ply
from ..scenes.polygon import outline_color
from .panels import pyplot, save

SPLIT_COLORS = {"train": "tab:blue", "val": "tab:orange", "test": "tab:green"}


def plot_rig_2d(cameras: dict[str, Cameras], outline: np.ndarray | None, path: str | Path,
                frustum: float = 0.6, title: str = "") -> Path:
    """Cameras as little view wedges around the outline; one colour per split."""
    fig, ax = pyplot().subplots(figsize=(6, 6))
    if outline is not None:
        pts = np.asarray(outline)
        ax.fill(pts[:, 0], pts[:, 1], color="0.9", zorder=0)
        seg = np.r_[pts, pts[:1]]
        s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(seg, axis=0), axis=1))]
        for k, color in enumerate(np.clip(outline_color(s[:-1] / s[-1]), 0, 1)):
            ax.plot(seg[k:k + 2, 0], seg[k:k + 2, 1], lw=3, color=color)
    for name, cams in cameras.items():
        if not len(cams):
            continue
        o, d = cams.rays()
        o, first, last = o[:, 0, 0], d[:, 0, 0], d[:, -1, 0]
        for k in range(len(cams)):
            wedge = np.array([o[k], o[k] + frustum * first[k], o[k] + frustum * last[k], o[k]])
            ax.plot(wedge[:, 0], wedge[:, 1], color=SPLIT_COLORS.get(name, "k"), lw=0.8,
                    label=f"{name} ({len(cams)})" if k == 0 else None)
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title or "camera rig (wedge: first and last pixel ray)")
    return save(fig, path, dpi=120)


def frustum_lines(cams: Cameras, depth: float = 0.5) -> np.ndarray:
    """Line segments ``[m, 2, 3]`` outlining each camera's view pyramid."""
    o, d = cams.rays()
    segs = []
    for k in range(len(cams)):
        tips = [o[k, 0, 0] + depth * c for c in (d[k, 0, 0], d[k, 0, -1], d[k, -1, -1], d[k, -1, 0])]
        for a in range(4):
            segs += [[o[k, 0, 0], tips[a]], [tips[a], tips[(a + 1) % 4]]]
    return np.array(segs)


def add_object_mesh(plotter, mesh_path: str | Path, texture_path: str | Path | None = None):
    """Add one of our PLYs to a pyvista plotter with its texture (its UVs + ``texture_path``), its vertex
    colours, or grey; returns the pyvista mesh."""
    import pyvista as pv

    ply = read_ply(mesh_path)
    mesh = pv.PolyData(ply["vertices"].astype(np.float64), np.c_[np.full(len(ply["faces"]), 3), ply["faces"]].ravel())
    if "colors" in ply:
        mesh.point_data["RGB"] = (linear_to_srgb(ply["colors"]) * 255).astype(np.uint8)
    if "uv" in ply and texture_path is not None and Path(texture_path).exists():
        uv = ply["uv"].astype(np.float32)
        uv[:, 1] = 1.0 - uv[:, 1]               # Mitsuba reads v from the image's top row, VTK from its bottom
        mesh.active_texture_coordinates = uv
        plotter.add_mesh(mesh, texture=pv.read_texture(str(texture_path)))
    elif "colors" in ply:
        plotter.add_mesh(mesh, scalars="RGB", rgb=True)
    else:
        plotter.add_mesh(mesh, color="lightgray")
    return mesh


def plot_rig_3d(cameras: dict[str, Cameras], mesh_path: str | Path | None, path: str | Path,
                texture_path: str | Path | None = None, window=(900, 700)) -> Path:
    """The object mesh with every camera's frustum, rendered off-screen by pyvista."""
    import pyvista as pv
    import vtk

    vtk.vtkObject.GlobalWarningDisplayOff()     # no display here: VTK warns about X on every plot
    pl = pv.Plotter(off_screen=True, window_size=list(window))
    if mesh_path is not None and Path(mesh_path).exists():
        add_object_mesh(pl, mesh_path, texture_path)
    for name, cams in cameras.items():
        if not len(cams):
            continue
        lines = pv.line_segments_from_points(frustum_lines(cams).reshape(-1, 3))
        pl.add_mesh(lines, color=SPLIT_COLORS.get(name, "black"), line_width=2, label=name)
    pl.add_legend(bcolor="white", size=(0.15, 0.12))
    pl.camera_position = "iso"
    pl.camera.zoom(1.1)
    pl.screenshot(str(path))
    pl.close()
    return Path(path)


def plot_mesh_comparison(learned: Mesh | str | Path, truth_path: str | Path | None, path: str | Path,
                         texture_path: str | Path | None = None, note: str = "", azimuth: float = 30.0,
                         elevation: float = 25.0, distance: float = 3.5, fov: float = 40.0,
                         center=(0.0, 0.0, 0.0), window=(1200, 600)) -> Path:
    """A PNG of two linked panels, the learned mesh beside the scene's own, seen from ``azimuth``/``elevation``
    degrees about the z axis through ``center`` at ``distance`` with a ``fov`` degree view; ``note`` goes below."""
    import pyvista as pv
    import vtk

    vtk.vtkObject.GlobalWarningDisplayOff()     # no display here: VTK warns about X on every plot
    learned = as_mesh(learned)
    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=list(window), border=False)
    pl.set_background("white")
    pl.subplot(0, 0)
    title = "learned" + (f" (density level {learned.level:.3g})" if learned.level is not None else "")
    pl.add_text(f"{title}\n{len(learned.vertices)} vertices, {len(learned.faces)} faces", font_size=10, color="black")
    if len(learned.faces):
        pl.add_mesh(learned.to_pyvista(), color="lightsteelblue", smooth_shading=True)
    else:
        pl.add_text("no surface", position="upper_right", color="red")
    if note:
        pl.add_text(note.replace(" (", "\n("), position="lower_left", font_size=9, color="black")
    pl.subplot(0, 1)
    if truth_path is not None and Path(truth_path).exists():
        add_object_mesh(pl, truth_path, texture_path)
        pl.add_text(f"ground truth\n{Path(truth_path).name}", font_size=10, color="black")
    else:
        pl.add_text("no ground-truth mesh", font_size=10, color="red")
    az, el, c = np.radians(azimuth), np.radians(elevation), np.asarray(center, float)
    eye = c + distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    for col in (0, 1):
        pl.subplot(0, col)
        pl.camera_position = [tuple(eye), tuple(c), (0.0, 0.0, 1.0)]
        pl.camera.view_angle = fov
    pl.link_views()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    pl.screenshot(str(path))
    pl.close()
    return Path(path)
