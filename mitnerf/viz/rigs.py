"""Camera rigs as pictures: a matplotlib plot in 2D, a pyvista scene (off-screen) in 3D."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data.cameras import Cameras
from ..data.color import linear_to_srgb
from ..scenes.ply import read_ply
from ..scenes.polygon import outline_color

SPLIT_COLORS = {"train": "tab:blue", "val": "tab:orange", "test": "tab:green"}


def plot_rig_2d(cameras: dict[str, Cameras], outline: np.ndarray | None, path: str | Path,
                frustum: float = 0.6, title: str = "") -> Path:
    """Cameras as little view wedges around the outline; one colour per split."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    fig, ax = plt.subplots(figsize=(6, 6))
    if outline is not None:
        pts = np.asarray(outline)
        ax.fill(pts[:, 0], pts[:, 1], color="0.9", zorder=0)
        seg = np.r_[pts, pts[:1]]
        s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(seg, axis=0), axis=1))]
        for k in range(len(pts)):
            ax.plot(seg[k:k + 2, 0], seg[k:k + 2, 1], lw=3,
                    color=np.clip(outline_color(np.array([s[k] / s[-1]]))[0], 0, 1))
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
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def frustum_lines(cams: Cameras, depth: float = 0.5) -> np.ndarray:
    """Line segments ``[m, 2, 3]`` outlining each camera's view pyramid."""
    o, d = cams.rays()
    segs = []
    for k in range(len(cams)):
        corners = [d[k, 0, 0], d[k, 0, -1], d[k, -1, -1], d[k, -1, 0]]
        tips = [o[k, 0, 0] + depth * c for c in corners]
        for a in range(4):
            segs.append([o[k, 0, 0], tips[a]])
            segs.append([tips[a], tips[(a + 1) % 4]])
    return np.array(segs)


def object_mesh(mesh_path: str | Path, texture_path: str | Path | None = None):
    """A pyvista mesh of one of our PLYs, with its vertex colours (or UVs + texture)."""
    import pyvista as pv

    ply = read_ply(mesh_path)
    faces = np.c_[np.full(len(ply["faces"]), 3), ply["faces"]].ravel()
    mesh = pv.PolyData(ply["vertices"].astype(np.float64), faces)
    texture = None
    if "colors" in ply:
        mesh.point_data["RGB"] = (linear_to_srgb(ply["colors"]) * 255).astype(np.uint8)
    if "uv" in ply and texture_path is not None and Path(texture_path).exists():
        uv = ply["uv"].astype(np.float32)
        uv[:, 1] = 1.0 - uv[:, 1]               # Mitsuba reads v from the image's top row, VTK from its bottom
        mesh.active_texture_coordinates = uv
        texture = pv.read_texture(str(texture_path))
    return mesh, texture


def add_object_mesh(plotter, mesh_path, texture_path=None):
    """Add one of our PLYs to a pyvista plotter with its texture, vertex colours, or grey."""
    mesh, texture = object_mesh(mesh_path, texture_path)
    if texture is not None:
        plotter.add_mesh(mesh, texture=texture)
    elif "RGB" in mesh.point_data:
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
        segs = frustum_lines(cams)
        lines = pv.line_segments_from_points(segs.reshape(-1, 3))
        pl.add_mesh(lines, color=SPLIT_COLORS.get(name, "black"), line_width=2, label=name)
    pl.add_legend(bcolor="white", size=(0.15, 0.12))
    pl.camera_position = "iso"
    pl.camera.zoom(1.1)
    path = Path(path)
    pl.screenshot(str(path))
    pl.close()
    return path
