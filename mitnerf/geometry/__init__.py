"""Geometry of a learned field and how far it is from the truth: :mod:`.mesh`, the ``density == level``
surface by marching cubes (``extract_mesh``) and the Chamfer distance between two triangle meshes
(``chamfer_distance``); :mod:`.outline`, the solid of a 2D field and its IoU with the true outline."""

from .mesh import (CHAMFER_RESOLUTION, LEVEL, ChamferResult, Mesh, auto_level, chamfer_distance, density_volume,
                   extract_mesh, field_chamfer, level_for_opacity, mesh_from_grid, mesh_from_ply, sample_surface)

__all__ = ["CHAMFER_RESOLUTION", "LEVEL", "ChamferResult", "Mesh", "auto_level", "chamfer_distance", "density_volume",
           "extract_mesh", "field_chamfer", "level_for_opacity", "mesh_from_grid", "mesh_from_ply", "sample_surface"]
